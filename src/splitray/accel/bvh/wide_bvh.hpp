#pragma once
// The traversal layout of a Bvh: the binary tree collapsed into nodes of up to kWideWidth
// children whose boxes are stored axis by axis (32 bytes per child), so that one SIMD slab
// test checks them all and a ray waits on a quarter (16 wide) or a third (8 wide) of the
// dependent memory loads of the binary tree. With AVX-512 a node may hold sixteen children
// (512 bytes, one 16-lane test): on the AMD EPYC 11% faster than eight on sibenik's diffuse
// rays, on the Intel Xeon 11-14% slower on primary rays and level elsewhere, so CMake picks
// the width by CPU (SPLITRAY_BVH_WIDTH); the answers are the same.
// Collapsing keeps every binary leaf; a leaf's triangles are stored as blocks of eight in
// SIMD rows (one cache-line-aligned block holds a whole leaf of the SAH builders, which cost
// leaves per eight triangles), tested at once by the watertight test with the very same
// operations (so the answers are bit-identical to testing them one by one).
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "splitray/accel/bvh/bvh_build.hpp"
#include "splitray/core/huge_page_allocator.hpp"
#include "splitray/core/triangle.hpp"

namespace splitray {

// SPLITRAY_BVH_WIDTH (CMake, chosen by CPU: docs/experiments.md) may ask for eight with AVX-512.
#if !defined(SPLITRAY_BVH_WIDTH)
#define SPLITRAY_BVH_WIDTH 16
#endif
#if defined(__AVX512F__) && SPLITRAY_BVH_WIDTH == 16
inline constexpr int kWideWidth = 16;
#else
inline constexpr int kWideWidth = 8;
#endif

struct alignas(64) WideNode {
  // planes[0..2] = lower x, y, z; planes[3..5] = upper x, y, z; empty slots have lower > upper.
  float planes[6][kWideWidth];
  std::uint32_t child[kWideWidth];  // interior: wide node index; leaf: first block
  std::uint32_t count[kWideWidth];  // leaf: blocks (> 0); interior or empty: 0
};
static_assert(sizeof(WideNode) == std::size_t{32} * kWideWidth);

inline constexpr int kBlockWidth = 8;

// Eight triangles in rows: v[0..2] = v0.xyz, v[3..5] = v1.xyz, v[6..8] = v2.xyz, one per lane.
// A leaf's last block repeats its last triangle in unused lanes.
struct alignas(64) TriangleBlock {
  // Left unset: the collapse writes every lane of every block (zeroing them first cost a
  // quarter of a binned build, the pages' first touch included).
  TriangleBlock() {}  // NOLINT(modernize-use-equals-default): `= default` would zero them
  float v[9][kBlockWidth];
  std::uint32_t id[kBlockWidth];
  Triangle triangle(int lane) const {
    return {{v[0][lane], v[1][lane], v[2][lane]},
            {v[3][lane], v[4][lane], v[5][lane]},
            {v[6][lane], v[7][lane], v[8][lane]}};
  }
  void set(int lane, const Triangle& t, std::uint32_t prim);
};
static_assert(sizeof(TriangleBlock) == 320);

// What rays cost in the wide layout, summed over rays (the benchmark's profile): wide nodes
// visited, child boxes tested in them (non-empty slots), leaves entered, blocks of eight
// triangles tested; and, of the rays that hit, the leaves entered that hold the triangle of
// the ray's closest hit (one, unless spatial splits put it in several leaves) and those
// entered after that hit was found (boxes crossed before it, holding nothing closer).
struct WideBvhCounts {
  std::uint64_t rays = 0, nodes = 0, boxes = 0, leaves = 0, blocks = 0;
  std::uint64_t hits = 0, hit_leaves = 0, late_leaves = 0;
};

class WideBvh {
 public:
  // Collapses `nodes` (root at 0, children side by side; leaves index `ids`) into the wide
  // nodes of least SAH cost (the dynamic program of Ylitie et al. 2017; every leaf is kept).
  void collapse(std::span<const BvhNode> nodes, std::span<const std::uint32_t> ids,
                std::span<const Triangle> triangles);
  // After a refit of the binary tree (same topology): its boxes and the moved triangles.
  void refit(std::span<const BvhNode> nodes, std::span<const Triangle> triangles);

  // The closest hit, or `so_far` (t = tmax and no hit when nothing came before) when nothing
  // closer is hit; any hit. As Bvh::intersect / occluded.
  Hit intersect(const Ray& ray, const Aabb& scene, float magnitude, Hit so_far) const;
  bool occluded(const Ray& ray, const Aabb& scene, float magnitude) const;
  // 1 to kPacketRays coherent rays (the same direction signs, directions within about 10
  // degrees of the first's; any directions of the same signs with `any_angle`) walked together,
  // one SIMD lane each (wide_bvh_packet.cpp), each with the answer of intersect() / occluded():
  // hits[i] (t = tmax when nothing is hit), and the rays that are occluded (bit per ray).
  // False / nullopt, with nothing walked, when the rays are not coherent, and always without
  // AVX-512 (kPackets).
  static constexpr int kPacketRays = 16;
#if defined(__AVX512F__)
  static constexpr bool kPackets = true;
#else
  static constexpr bool kPackets = false;
#endif
  bool intersect_packet(std::span<const Ray> rays, const Aabb& scene, float magnitude, Hit* hits,
                        bool any_angle = false) const;
  std::optional<unsigned> occluded_packet(std::span<const Ray> rays, const Aabb& scene,
                                          float magnitude, bool any_angle = false) const;
  // 1 to kPacketRays rays of any directions (the groups that make no packet), each with the
  // answer of intersect() / occluded() (hits[i]: t = tmax when nothing is hit; occluded[i]: 0
  // or 1), after one test of the root for eight rays at a time (wide_bvh_group.cpp). False, with
  // nothing walked, without AVX and FMA.
  bool intersect_group(std::span<const Ray> rays, const Aabb& scene, float magnitude,
                       Hit* hits) const;
  bool occluded_group(std::span<const Ray> rays, const Aabb& scene, float magnitude,
                      std::uint8_t* occluded) const;
  // intersect(), adding what the ray cost to `counts` (a slower copy of the same walk, after
  // the plain walk).
  Hit intersect_counted(const Ray& ray, const Aabb& scene, float magnitude, const Hit& so_far,
                        WideBvhCounts& counts) const;

  std::size_t bytes() const {
    return nodes_.size() * sizeof(WideNode) + source_.size() * sizeof(std::uint32_t) +
           blocks_.size() * sizeof(TriangleBlock);
  }
  std::span<const WideNode> nodes() const { return nodes_; }
  std::span<const TriangleBlock> blocks() const { return blocks_; }

 private:
  HugePageVector<WideNode> nodes_;        // root at 0
  std::vector<std::uint32_t> source_;     // binary node of each slot (kInvalidId: empty)
  HugePageVector<TriangleBlock> blocks_;  // leaf triangles, leaf after leaf
};

}  // namespace splitray

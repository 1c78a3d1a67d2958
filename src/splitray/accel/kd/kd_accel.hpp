#pragma once
// The SAH kd-tree behind the common interface.
#include "splitray/accel/accel.hpp"
#include "splitray/accel/kd/kd_build.hpp"
#include "splitray/accel/kd/kd_leaf.hpp"
#include "splitray/accel/kd/kd_tree.hpp"
#include "splitray/accel/kd/kd_wide.hpp"
#include "splitray/core/timer.hpp"

namespace splitray {

// Builders of --accel kd, the default first.
std::vector<std::string> kd_builder_names();
// The builder function of a name; throws Error on an unknown name.
KdBuilder kd_builder(const std::string& name);
std::unique_ptr<Accel> make_kd(std::span<const Triangle> triangles, const BuildConfig& config);

// A built kd-tree with its triangles in leaf order, traversed front to back with a small fixed
// stack. Cells are widened slightly (relative to the scene's and the ray's scale) when a ray is
// clipped against them, so rounding at split planes, rays in or parallel to planes and hits at
// shared edges and vertices never lose the closest hit: results equal `brute` exactly.
//
// For traversal the tree is also kept as (1) the leaves' triangles in SIMD rows (kd_leaf.hpp, 8
// triangles per exact test with AVX) and (2) a wide layout of three binary levels per node
// (kd_wide.hpp), which every walk uses: a single ray's walk clips the ray against a node's 7
// planes at once (kd_wide_traverse.cpp; in SIMD with AVX2, else plane by plane with the same
// float operations). The batched intersect traces coherent groups of 16 rays (AVX-512; else 8)
// as packets, plane by plane through the wide nodes (kd_packet.cpp, AVX2 builds) and the other
// rays in interleaved walks. Every path gives the single-ray answer, bit for bit.
class KdAccel final : public Accel {
 public:
  // `tree` references `triangles` by index. Statistics are taken from the tree; build_ms is
  // measured by `build_timer` when the structure is ready.
  KdAccel(KdTree tree, std::span<const Triangle> triangles, const BuildConfig& config,
          std::uint64_t cost_evals, const Timer& build_timer);

  Hit closest_hit(const Ray& ray) const override;
  bool any_hit(const Ray& ray) const override;
  void closest_hits(std::span<const Ray> rays, std::span<Hit> hits) const override;
  void any_hits(std::span<const Ray> rays, std::span<std::uint8_t> occluded) const override;
  const AccelStats& stats() const override { return stats_; }

  const KdTree& tree() const { return tree_; }

  // Deepest wide layout (kd_wide.hpp) the single-ray traversal's stack takes.
  static constexpr int kWideDepthLimit = 22;
  // What a walk of the wide layout reads (kd_wide_traverse.cpp).
  struct WideView {
    const KdWideNode* nodes;
    const KdWideLeaf* leaves;
    const std::uint32_t* ids;
    const KdLeafTriangles* rows;
    std::uint32_t root;
  };

 private:
  // The single-ray walk of the wide layout (kd_wide_traverse.cpp).
  template <bool kAnyHit>
  bool traverse(const Ray& ray, Hit& hit) const;
  // Rays the walk cannot take (NaN, infinite or zero direction or origin): every leaf tested.
  template <bool kAnyHit>
  bool scan(const Ray& ray, Hit& hit) const;
  // Closest hits of kPacketRays rays (kd_packet.cpp): as one packet of 16 on AVX-512 CPUs,
  // else (or when the 16 do not suit one packet) as packets of 8. Returns a bit per group of
  // 8 rays traced; the other groups' hits are not written. Results equal intersect(ray).
#if defined(__AVX512F__)
  static constexpr int kPacketRays = 16;
#else
  static constexpr int kPacketRays = 8;
#endif
  unsigned intersect_packets(const Ray* rays, Hit* hits) const;
  // One packet of F::kLanes rays (F: simd::Float8 or Float16); false, with nothing written,
  // when the rays do not suit one (direction signs differ, an empty or untraversable ray).
  template <class F>
  bool intersect_packet(const Ray* rays, Hit* hits) const;
  // Closest hits (into hits[i]) or occlusion (into occluded[i]) of rays i = which[k], k < n,
  // several walks interleaved (kd_wide_traverse.cpp).
  template <bool kAnyHit>
  void walk_interleaved(const Ray* rays, const std::uint32_t* which, std::size_t n, Hit* hits,
                        std::uint8_t* occluded) const;
  // The same, one walk after the other.
  template <bool kAnyHit>
  void walk_each(const Ray* rays, const std::uint32_t* which, std::size_t n, Hit* hits,
                 std::uint8_t* occluded) const;
  WideView wide_view() const;

  KdTree tree_;
  KdWideTree wide_;                 // the same tree, three levels per node, for the walks
  KdLeafTriangles leaf_triangles_;  // the triangles of every leaf, in the order of prim_ids
  float coord_scale_ = 0;           // largest absolute coordinate of the root cell
  // Interleave walks only for trees larger than about an L2 cache: in a tree that stays in
  // cache there is no load latency to hide, and single walks are faster (measured: Cornell box
  // diffuse rays 2x faster one by one, the dragon's 1.7x faster interleaved).
  static constexpr std::size_t kInterleaveBytes = std::size_t{1} << 20;
  bool interleave_ = false;
  AccelStats stats_;
};

}  // namespace splitray

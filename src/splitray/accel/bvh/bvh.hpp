#pragma once
// A BVH over triangles: built as a binary tree of 32-byte nodes (children side by side;
// what builders, refit and statistics work on), traversed in its
// wide collapsed form (wide_bvh.hpp: one SIMD slab test per 16 children with AVX-512, else 8,
// nearest child first, fixed stack; a leaf's triangles copied into one block of eight lanes).
// Refitting moves the boxes and triangles for meshes that deform with fixed topology.
//
//   Bvh bvh = Bvh::build(triangles, "sbvh", BvhBuildOptions::from(config));
//   Hit hit = bvh.intersect(ray);
//   bvh.refit(next_frame_triangles);  // same triangle count and order
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/accel/bvh/bvh_build.hpp"
#include "splitray/accel/bvh/wide_bvh.hpp"

namespace splitray {

class Bvh {
 public:
  Bvh() = default;

  // Builders: "binned", "sbvh" (ours), "embree" (rtcBuildBVH, high quality, spatial splits).
  static std::vector<std::string> builder_names();
  static Bvh build(std::span<const Triangle> triangles, const std::string& builder,
                   const BvhBuildOptions& options);
  // Lays out a built piece tree whose leaves reference `triangles`.
  static Bvh from_pieces(std::span<const Triangle> triangles, const BvhPiece& root);

  // Moves the vertices: `triangles` must be the same triangles (count and order) deformed.
  // Leaf boxes become the bounds of their triangles, interior boxes the union of their children.
  void refit(std::span<const Triangle> triangles);

  Hit intersect(const Ray& ray) const;
  bool occluded(const Ray& ray) const;
  // The same answers for many rays on this thread, walked in packets (wide_bvh_packet.cpp).
  void intersect(std::span<const Ray> rays, std::span<Hit> hits) const;
  void occluded(std::span<const Ray> rays, std::span<std::uint8_t> occluded) const;
  // intersect(), adding what the ray cost in the wide layout to `counts` (benchmark profile).
  Hit intersect_counted(const Ray& ray, WideBvhCounts& counts) const;

  // Node statistics and SAH cost (K_T per interior node, K_I per reference, by box area).
  void fill_stats(AccelStats& stats, float traversal_cost, float intersection_cost) const;

  std::span<const BvhNode> nodes() const { return nodes_; }
  const WideBvh& wide() const { return wide_; }
  std::span<const std::uint32_t> prim_ids() const { return ids_; }  // leaf references, leaf order
  std::size_t triangle_count() const { return triangle_count_; }
  const Aabb& bounds() const { return scene_; }
  std::size_t bytes() const;

 private:
  void update_scene_bounds(std::span<const Triangle> triangles);

  std::vector<BvhNode> nodes_;      // the binary tree, root at 0
  WideBvh wide_;                    // the traversal layout
  std::vector<std::uint32_t> ids_;  // triangle id of each leaf reference
  std::size_t triangle_count_ = 0;
  Aabb scene_;  // bounds of all triangles (conservative ray padding)
  float magnitude_ = 0;
  std::uint64_t cost_evals_ = 0;  // SAH evaluations of the build
};

}  // namespace splitray

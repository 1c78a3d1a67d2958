#pragma once
// The SAH kd-tree behind the common interface.
#include "splitray/accel/accel.hpp"
#include "splitray/accel/kd/kd_build.hpp"
#include "splitray/accel/kd/kd_tree.hpp"
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
class KdAccel final : public Accel {
 public:
  // `tree` references `triangles` by index. Statistics are taken from the tree; build_ms is
  // measured by `build_timer` when the structure is ready.
  KdAccel(KdTree tree, std::span<const Triangle> triangles, const BuildConfig& config,
          std::uint64_t cost_evals, const Timer& build_timer);

  Hit intersect(const Ray& ray) const override;
  bool occluded(const Ray& ray) const override;
  void intersect(std::span<const Ray> rays, std::span<Hit> hits) const override;
  void occluded(std::span<const Ray> rays, std::span<std::uint8_t> occluded) const override;
  const AccelStats& stats() const override { return stats_; }

  const KdTree& tree() const { return tree_; }

 private:
  template <bool kAnyHit>
  bool traverse(const Ray& ray, Hit& hit) const;
  template <bool kAnyHit>
  bool scan(const Ray& ray, Hit& hit) const;

  KdTree tree_;
  std::vector<Triangle> leaf_triangles_;  // the triangle of every entry of tree_.prim_ids
  float coord_scale_ = 0;                 // largest absolute coordinate of the root cell
  AccelStats stats_;
};

}  // namespace splitray

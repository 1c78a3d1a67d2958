#include "splitray/accel/brute/brute.hpp"

#include "splitray/accel/sah_cost.hpp"
#include "splitray/core/timer.hpp"

namespace splitray {

namespace {

class BruteAccel final : public Accel {
 public:
  BruteAccel(std::span<const Triangle> triangles, const BuildConfig& config)
      : triangles_(triangles.begin(), triangles.end()) {
    Timer timer;
    Aabb box;
    for (const Triangle& t : triangles_) box.extend(t.bounds());
    stats_.accel = "brute";
    stats_.builder = config.builder;
    stats_.prims = stats_.prim_refs = triangles_.size();
    stats_.nodes = stats_.leaves = 1;
    stats_.mean_leaf_prims = static_cast<double>(triangles_.size());
    stats_.bytes = triangles_.size() * sizeof(Triangle);
    const SahConstants k = config.sah(kSharedSah);
    SahCost cost(box, k.traversal, k.intersection);
    cost.leaf(box, triangles_.size());
    cost.report(stats_);
    stats_.build_ms = timer.ms();
  }

  Hit closest_hit(const Ray& ray) const override {
    const WatertightRay wray(ray);
    Hit hit;
    hit.t = ray.tmax;
    for (std::size_t i = 0; i < triangles_.size(); ++i)
      intersect_triangle(wray, triangles_[i], static_cast<std::uint32_t>(i), ray.tmin, hit);
    if (!hit.found()) hit.t = kInfinity;
    return hit;
  }

  bool any_hit(const Ray& ray) const override {
    const WatertightRay wray(ray);
    float t, u, v;
    for (const Triangle& tri : triangles_)
      if (intersect_triangle(wray, tri, ray.tmin, ray.tmax, t, u, v)) return true;
    return false;
  }

  const AccelStats& stats() const override { return stats_; }

 private:
  std::vector<Triangle> triangles_;
  AccelStats stats_;
};

}  // namespace

std::unique_ptr<Accel> make_brute(std::span<const Triangle> triangles, const BuildConfig& config) {
  return std::make_unique<BruteAccel>(triangles, config);
}

}  // namespace splitray

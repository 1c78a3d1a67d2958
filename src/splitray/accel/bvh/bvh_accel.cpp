#include "splitray/accel/bvh/bvh_accel.hpp"

#include "splitray/accel/bvh/bvh.hpp"
#include "splitray/core/timer.hpp"

namespace splitray {

namespace {

class BvhAccel final : public Accel {
 public:
  BvhAccel(std::span<const Triangle> triangles, const BuildConfig& config)
      : traversal_cost_(config.sah(kSharedSah).traversal),
        intersection_cost_(config.sah(kSharedSah).intersection) {
    Timer timer;
    bvh_ = Bvh::build(triangles, config.builder, BvhBuildOptions::from(config));
    stats_.build_ms = timer.ms();
    stats_.accel = "bvh";
    stats_.builder = config.builder;
    bvh_.fill_stats(stats_, traversal_cost_, intersection_cost_);
  }

  Hit closest_hit(const Ray& ray) const override { return bvh_.intersect(ray); }
  bool any_hit(const Ray& ray) const override { return bvh_.occluded(ray); }
  const AccelStats& stats() const override { return stats_; }

  bool refit_to(std::span<const Triangle> triangles) override {
    Timer timer;
    bvh_.refit(triangles);
    stats_.build_ms = timer.ms();
    bvh_.fill_stats(stats_, traversal_cost_, intersection_cost_);
    return true;
  }

 private:
  Bvh bvh_;
  AccelStats stats_;
  float traversal_cost_, intersection_cost_;
};

}  // namespace

std::unique_ptr<Accel> make_bvh(std::span<const Triangle> triangles, const BuildConfig& config) {
  return std::make_unique<BvhAccel>(triangles, config);
}

}  // namespace splitray

#include "splitray/accel/bih/bih_accel.hpp"

#include "splitray/accel/bih/bih.hpp"
#include "splitray/core/timer.hpp"

namespace splitray {

namespace {

class BihAccel final : public Accel {
 public:
  BihAccel(std::span<const Triangle> triangles, const BuildConfig& config) {
    const BihBuildOptions options =
        BihBuildOptions::from(config, parse_bih_heuristic(config.builder));
    Timer timer;
    bih_ = Bih::build(triangles, options);
    stats_.build_ms = timer.ms();
    stats_.accel = "bih";
    stats_.builder = config.builder;
    const SahConstants k = config.sah(kSharedSah);
    bih_.fill_stats(stats_, k.traversal, k.intersection);
  }

  Hit closest_hit(const Ray& ray) const override { return bih_.intersect(ray); }
  bool any_hit(const Ray& ray) const override { return bih_.occluded(ray); }
  const AccelStats& stats() const override { return stats_; }

 private:
  Bih bih_;
  AccelStats stats_;
};

}  // namespace

std::unique_ptr<Accel> make_bih(std::span<const Triangle> triangles, const BuildConfig& config) {
  return std::make_unique<BihAccel>(triangles, config);
}

}  // namespace splitray

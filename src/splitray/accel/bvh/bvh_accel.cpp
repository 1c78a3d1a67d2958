#include "splitray/accel/bvh/bvh_accel.hpp"

#include "splitray/accel/bvh/bvh.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"

namespace splitray {

namespace {

class BvhAccel final : public Accel {
 public:
  BvhAccel(Bvh bvh, const BuildConfig& config, double build_ms)
      : bvh_(std::move(bvh)), sah_(config.sah(kSharedSah)) {
    stats_.accel = "bvh";
    stats_.builder = config.builder;
    stats_.build_ms = build_ms;
    bvh_.fill_stats(stats_, sah_.traversal, sah_.intersection);
  }

  Hit closest_hit(const Ray& ray) const override { return bvh_.intersect(ray); }
  bool any_hit(const Ray& ray) const override { return bvh_.occluded(ray); }
  const AccelStats& stats() const override { return stats_; }

  // Batched calls: packets of neighbouring rays (each ray's answer is its single-ray answer).
  void closest_hits(std::span<const Ray> rays, std::span<Hit> hits) const override {
    parallel_chunks(rays.size(), 256, [&](std::size_t begin, std::size_t end) {
      bvh_.intersect(rays.subspan(begin, end - begin), hits.subspan(begin, end - begin));
    });
  }
  void any_hits(std::span<const Ray> rays, std::span<std::uint8_t> result) const override {
    parallel_chunks(rays.size(), 256, [&](std::size_t begin, std::size_t end) {
      bvh_.occluded(rays.subspan(begin, end - begin), result.subspan(begin, end - begin));
    });
  }

  bool refit_to(std::span<const Triangle> triangles) override {
    Timer timer;
    bvh_.refit(triangles);
    stats_.build_ms = timer.ms();
    bvh_.fill_stats(stats_, sah_.traversal, sah_.intersection);
    return true;
  }

 private:
  Bvh bvh_;
  SahConstants sah_;
  AccelStats stats_;
};

}  // namespace

std::unique_ptr<Accel> make_bvh(std::span<const Triangle> triangles, const BuildConfig& config) {
  Timer timer;
  Bvh bvh = Bvh::build(triangles, config.builder, BvhBuildOptions::from(config));
  return wrap_bvh(std::move(bvh), config, timer.ms());
}

std::unique_ptr<Accel> wrap_bvh(Bvh bvh, const BuildConfig& config, double build_ms) {
  return std::make_unique<BvhAccel>(std::move(bvh), config, build_ms);
}

}  // namespace splitray

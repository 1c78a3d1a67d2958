#include "animate_refit.hpp"

#include "splitray/core/errors.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/render/ray_sets.hpp"

namespace splitray::app {

namespace {

double timed_trace(const Accel& accel, std::span<const Ray> rays, std::vector<Hit>& hits) {
  hits.assign(rays.size(), Hit{});
  const Timer timer;
  accel.intersect(rays, hits);
  return timer.ms();
}

}  // namespace

std::vector<RefitFrame> refit_frames(const std::vector<std::vector<Triangle>>& frames,
                                     const BuildConfig& config, std::size_t rays,
                                     std::uint64_t seed,
                                     const std::function<void(double)>& progress) {
  BuildConfig base = config;
  if (base.builder.empty()) base.builder = "binned";
  if (base.builder != "binned" && base.builder != "sbvh")
    throw Error("--accel bvh --refit --builder " + base.builder,
                "refitting takes the BVH builders binned or sbvh");
  BuildConfig reference = base;
  reference.builder = "sbvh";

  std::vector<RefitFrame> rows(frames.size());
  std::unique_ptr<Accel> refitted;
  std::vector<Hit> hits_rebuild, hits_refit;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const std::vector<Triangle>& tris = frames[i];
    RefitFrame& row = rows[i];
    Timer timer;
    const auto rebuilt = make_accel("bvh", tris, base);
    row.rebuild_ms = timer.ms();
    timer.reset();
    if (!refitted)
      refitted = make_accel("bvh", tris, base);
    else if (!refitted->refit(tris))
      throw Error("--refit", "the BVH cannot refit");
    row.refit_ms = timer.ms();
    if (base.builder == reference.builder) {
      row.reference_ms = row.rebuild_ms;
    } else {
      timer.reset();
      const auto exact = make_accel("bvh", tris, reference);
      row.reference_ms = timer.ms();
    }
    row.sah_rebuild = rebuilt->stats().sah_cost.value_or(0);
    row.sah_refit = refitted->stats().sah_cost.value_or(0);
    row.nodes_rebuild = rebuilt->stats().nodes;
    row.nodes_refit = refitted->stats().nodes;
    row.evals_rebuild = rebuilt->stats().cost_evals;
    if (rays > 0) {
      const std::vector<Ray> set = make_rays(tris, RayKind::primary, seed + i, rays);
      // Alternate the order so that neither tree always runs on warm caches.
      if (i % 2 == 0) {
        row.trace_ms_rebuild = timed_trace(*rebuilt, set, hits_rebuild);
        row.trace_ms_refit = timed_trace(*refitted, set, hits_refit);
      } else {
        row.trace_ms_refit = timed_trace(*refitted, set, hits_refit);
        row.trace_ms_rebuild = timed_trace(*rebuilt, set, hits_rebuild);
      }
      for (std::size_t r = 0; r < set.size(); ++r)
        row.hit_mismatches +=
            hits_rebuild[r].prim != hits_refit[r].prim || hits_rebuild[r].t != hits_refit[r].t;
    }
    progress(static_cast<double>(i + 1) / static_cast<double>(frames.size()));
  }
  return rows;
}

}  // namespace splitray::app

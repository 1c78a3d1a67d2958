#pragma once
// `splitray animate --accel bvh --refit`: one BVH built on the first frame and refitted to
// every later frame (same triangles, moved), beside a BVH rebuilt from scratch by the same
// builder and the quality reference `sbvh`, all traced with the same primary rays per frame.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <vector>

#include "splitray/accel/accel.hpp"

namespace splitray::app {

struct RefitFrame {
  double rebuild_ms = 0, refit_ms = 0, reference_ms = 0;  // frame 0: refit_ms = its build
  double sah_rebuild = 0, sah_refit = 0;
  std::size_t nodes_rebuild = 0, nodes_refit = 0;  // refit: the first frame's tree's
  std::uint64_t evals_rebuild = 0;
  double trace_ms_rebuild = 0, trace_ms_refit = 0;
  std::size_t hit_mismatches = 0;  // rays whose hit differs between refitted and rebuilt
};

// `config.builder` (binned when empty) builds; `progress` gets the fraction done.
std::vector<RefitFrame> refit_frames(const std::vector<std::vector<Triangle>>& frames,
                                     const BuildConfig& config, std::size_t rays,
                                     std::uint64_t seed,
                                     const std::function<void(double)>& progress);

}  // namespace splitray::app

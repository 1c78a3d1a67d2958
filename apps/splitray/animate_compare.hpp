#pragma once
// `splitray animate FRAMES --compare`: every animation strategy (animated_accel.hpp) on the
// same frames, each frame's update and frame-pass trace timed (strategies in a rotating order
// so that none always runs on warm caches), hits compared with the kd rebuild's; the medians
// over frames 1.., per-frame rows (CSV) and a plot of both times per frame.
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "frame_pass.hpp"
#include "splitray/accel/accel.hpp"
#include "splitray/accel/predict/split_predictor.hpp"
#include "splitray/io/frames.hpp"

namespace splitray::app {

struct CompareOptions {
  std::vector<std::string> strategies;  // empty: all
  BuildConfig build;
  PredictorConfig predictor;
  FramePassSetup pass;
};

struct CompareResult {
  nlohmann::ordered_json summary;  // per strategy: medians, SAH cost, ratios to Embree's best
  std::string csv;                 // strategy,frame,update_ms,trace_ms,frame_ms,sah_cost,...
  std::string markdown;
};

CompareResult compare_strategies(const FrameSequence& sequence,
                                 const std::vector<std::vector<Triangle>>& frames,
                                 const CompareOptions& options,
                                 const std::function<void(double)>& progress);

}  // namespace splitray::app

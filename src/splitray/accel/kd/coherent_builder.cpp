// First version of the coherent rebuild: the predicted golden rebuild of paper 000
// (predicted_builder.hpp) behind the coherent interface, so that the animation interface
// can be written against it while the coherent method itself is built.
#include "splitray/accel/kd/coherent_builder.hpp"

#include "splitray/accel/kd/predicted_builder.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/timer.hpp"

namespace splitray {

struct KdCoherentBuilder::State {
  BuildConfig config;
  SplitPredictor predictor;
  std::size_t triangles = 0;
  std::size_t frame = 0;
};

KdCoherentBuilder::KdCoherentBuilder(const BuildConfig& config, const PredictorConfig& predictor)
    : state_(std::make_unique<State>(State{config, SplitPredictor(predictor)})) {}
KdCoherentBuilder::~KdCoherentBuilder() = default;
KdCoherentBuilder::KdCoherentBuilder(KdCoherentBuilder&&) noexcept = default;
KdCoherentBuilder& KdCoherentBuilder::operator=(KdCoherentBuilder&&) noexcept = default;

void KdCoherentBuilder::reset() {
  state_->predictor.clear();
  state_->frame = 0;
}

std::unique_ptr<KdAccel> KdCoherentBuilder::next_frame(std::span<const Triangle> triangles,
                                                       CoherentFrameStats& stats) {
  State& s = *state_;
  if (triangles.empty()) throw Error("kd coherent rebuild", "the frame has no triangles");
  if (s.frame > 0 && triangles.size() != s.triangles)
    throw Error("kd coherent rebuild",
                "frame " + std::to_string(s.frame) + " has " + std::to_string(triangles.size()) +
                    " triangles, the previous frame " + std::to_string(s.triangles));
  stats = CoherentFrameStats{};
  stats.from_scratch = s.frame == 0;
  if (stats.from_scratch) stats.reason = "first frame";
  const Timer timer;
  PredictedBuildStats predicted;
  std::unique_ptr<KdAccel> accel = make_kd_predicted(triangles, s.config, s.predictor, predicted);
  stats.total_ms = timer.ms();
  stats.reoptimised_nodes = predicted.predicted_nodes;
  stats.rebuilt_nodes = accel->stats().nodes - predicted.predicted_nodes;
  stats.sah_cost = accel->stats().sah_cost.value_or(0);
  s.triangles = triangles.size();
  ++s.frame;
  return accel;
}

}  // namespace splitray

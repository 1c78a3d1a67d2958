#include "splitray/accel/predict/split_predictor.hpp"

#include <algorithm>
#include <cmath>

#include "splitray/core/errors.hpp"

namespace splitray {

namespace {
constexpr double kInitialErrorPower = 0.05 * 0.05;  // Wiener: before any error was seen
constexpr double kErrorDecay = 0.3;                 // weight of the newest squared error
}  // namespace

PredictorKind parse_predictor_kind(const std::string& name) {
  if (name == "none") return PredictorKind::none;
  if (name == "kalman") return PredictorKind::kalman;
  if (name == "wiener") return PredictorKind::wiener;
  throw Error("--predictor", "'" + name + "' is not a predictor (known: none, kalman, wiener)");
}

std::string predictor_name(PredictorKind kind) {
  switch (kind) {
    case PredictorKind::none:
      return "none";
    case PredictorKind::kalman:
      return "kalman";
    case PredictorKind::wiener:
      return "wiener";
  }
  return "?";
}

std::optional<SplitPrediction> SplitPredictor::predict(std::uint64_t path, int depth) const {
  if (config_.kind == PredictorKind::none || path == 0) return std::nullopt;
  const auto it = tracks_.find(path);
  if (it == tracks_.end() || it->second.depth != depth) return std::nullopt;
  const Track& t = it->second;
  SplitPrediction p;
  p.axis = t.axis;
  double variance;
  if (const auto* k = std::get_if<KalmanFilter>(&t.filter)) {
    const KalmanPrediction kp = k->predict();
    p.fraction = kp.position;
    variance = kp.variance;
  } else {
    p.fraction = std::get<WienerPredictor>(t.filter).predict();
    variance = t.error_power;
  }
  // A split lies inside its cell: a prediction beyond it is no better than the nearest face.
  if (std::isfinite(p.fraction)) p.fraction = std::clamp(p.fraction, 0.0, 1.0);
  p.half_width = std::max(config_.sigmas * std::sqrt(variance), config_.min_half_width);
  if (!(p.half_width <= config_.max_half_width) || !std::isfinite(p.fraction)) return std::nullopt;
  p.max_cost_ratio = t.cost_ratio * (1 + config_.cost_tolerance);
  p.check_axes = t.margin < config_.axis_margin || t.since_full + 1 >= config_.refresh_frames;
  return p;
}

void SplitPredictor::update(std::span<const SplitObservation> observations) {
  if (config_.kind == PredictorKind::none) return;
  ++frame_;
  for (const SplitObservation& o : observations) {
    if (o.path == 0) continue;
    auto [it, fresh] = tracks_.try_emplace(o.path);
    Track& t = it->second;
    if (fresh || t.depth != o.depth || t.axis != o.axis) {
      // New node or the axis changed: restart the filter at this observation.
      t = Track{};
      t.depth = o.depth;
      t.axis = o.axis;
      t.error_power = kInitialErrorPower;
      if (config_.kind == PredictorKind::kalman)
        t.filter = KalmanFilter(config_.kalman, o.fraction);
      else
        t.filter = WienerPredictor(config_.wiener, o.fraction);
    } else {
      std::visit([&](auto& f) { f.update(o.fraction); }, t.filter);
    }
    if (o.predicted) {
      const double e = o.fraction - *o.predicted;
      t.error_power = (1 - kErrorDecay) * t.error_power + kErrorDecay * e * e;
    }
    if (o.axis_margin) {
      t.margin = *o.axis_margin;
      t.since_full = 0;
    } else {
      ++t.since_full;
    }
    t.cost_ratio = o.cost_ratio;
    t.frame = frame_;
  }
  // Nodes that no longer exist (or were not searched) lose their history.
  std::erase_if(tracks_, [&](const auto& entry) { return entry.second.frame != frame_; });
}

}  // namespace splitray

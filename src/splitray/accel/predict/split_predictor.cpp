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

namespace {
std::uint64_t hash_path(std::uint64_t path) {  // splitmix64's finaliser
  path ^= path >> 30;
  path *= 0xbf58476d1ce4e5b9ull;
  path ^= path >> 27;
  path *= 0x94d049bb133111ebull;
  return path ^ (path >> 31);
}
}  // namespace

std::uint32_t SplitPredictor::find(std::uint64_t path) const {
  if (keys_.empty() || path == 0) return kNone;
  const std::size_t mask = keys_.size() - 1;
  for (std::size_t i = hash_path(path) & mask;; i = (i + 1) & mask) {
    if (keys_[i] == path) return slots_[i];
    if (keys_[i] == 0) return kNone;
  }
}

void SplitPredictor::rebuild_index() {
  std::size_t capacity = 16;
  while (capacity < 2 * tracks_.size()) capacity *= 2;
  keys_.assign(capacity, 0);
  slots_.assign(capacity, 0);
  const std::size_t mask = capacity - 1;
  for (std::size_t t = 0; t < tracks_.size(); ++t) {
    std::size_t i = hash_path(tracks_[t].path) & mask;
    while (keys_[i] != 0) i = (i + 1) & mask;
    keys_[i] = tracks_[t].path;
    slots_[i] = static_cast<std::uint32_t>(t);
  }
}

void SplitPredictor::clear() {
  tracks_.clear();
  keys_.clear();
  slots_.clear();
  live_ = 0;
}

std::optional<SplitPrediction> SplitPredictor::predict(std::uint64_t path, int depth) const {
  if (config_.kind == PredictorKind::none || path == 0) return std::nullopt;
  const std::uint32_t slot = find(path);
  if (slot == kNone) return std::nullopt;
  const Track& t = tracks_[slot];
  if (t.frame != frame_ || t.depth != depth) return std::nullopt;
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
  const std::uint64_t previous = frame_++;
  bool grown = false;
  for (const SplitObservation& o : observations) {
    if (o.path == 0) continue;
    std::uint32_t slot = find(o.path);
    if (slot == kNone) {
      slot = static_cast<std::uint32_t>(tracks_.size());
      tracks_.emplace_back();
      tracks_.back().path = o.path;
      // Indexed at once unless the index is too full: then it is rebuilt below (paths are
      // unique within a frame, so nothing looks the new track up before that).
      if (!grown && 2 * tracks_.size() <= keys_.size()) {
        const std::size_t mask = keys_.size() - 1;
        std::size_t i = hash_path(o.path) & mask;
        while (keys_[i] != 0) i = (i + 1) & mask;
        keys_[i] = o.path;
        slots_[i] = slot;
      } else {
        grown = true;
      }
    }
    Track& t = tracks_[slot];
    // A node new, unseen in the last frame or whose axis changed restarts at this observation.
    if (t.frame != previous || t.frame == 0 || t.depth != o.depth || t.axis != o.axis) {
      const std::uint64_t path = t.path;
      t = Track{};
      t.path = path;
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
  // Nodes that no longer exist (or were not searched) lose their history: dropped in bulk
  // once they are a quarter of the tracks (until then predict() ignores them).
  live_ = 0;
  for (const Track& t : tracks_) live_ += t.frame == frame_;
  if (grown || 4 * (tracks_.size() - live_) > tracks_.size()) {
    std::erase_if(tracks_, [&](const Track& t) { return t.frame != frame_; });
    rebuild_index();
  }
}

}  // namespace splitray

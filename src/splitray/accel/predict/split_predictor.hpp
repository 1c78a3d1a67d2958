#pragma once
// Per-node split prediction for animated kd rebuilds (paper 000 §5). A node is known by its
// path from the root (path_child), its split position by the fraction of its cell on the
// split axis, so that translation and scaling of the node's content predict themselves.
// After each frame the builder's observations (axis and fraction per searched node) update
// one filter per path; a node whose axis changed restarts its filter.
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <variant>
#include <vector>

#include "splitray/accel/predict/kalman.hpp"
#include "splitray/accel/predict/wiener.hpp"

namespace splitray {

enum class PredictorKind { none, kalman, wiener };
PredictorKind parse_predictor_kind(const std::string& name);  // Error naming --predictor
std::string predictor_name(PredictorKind kind);

// Path codes: the root is 1; a child appends one bit (0 below, 1 above). Depths above 62
// have no code (0) and are never predicted.
inline constexpr std::uint64_t kRootPath = 1;
inline std::uint64_t path_child(std::uint64_t path, bool above) {
  if (path == 0 || (path >> 62) != 0) return 0;
  return (path << 1) | (above ? 1u : 0u);
}

struct PredictorConfig {
  PredictorKind kind = PredictorKind::kalman;
  KalmanConfig kalman;
  WienerConfig wiener;
  double sigmas = 3;             // bracket half width = sigmas * predicted standard deviation
  double min_half_width = 0.01;  // of the cell, so that a bracket always holds a few events
  double max_half_width = 0.2;   // wider than this, the prediction is not worth using
  double axis_margin = 0.03;     // trust the predicted axis when the others cost this much more
  int refresh_frames = 8;        // re-check the other axes of a node at least this often
  // A predicted split whose cost (relative to the node's leaf cost) exceeds last frame's by
  // more than this share is a local minimum the bracket trapped: search fully instead.
  double cost_tolerance = 0.02;
};

struct SplitPrediction {
  int axis = 0;
  double fraction = 0;        // predicted split position as a fraction of the cell on `axis`
  double half_width = 0;      // of the bracket, in fractions of the cell
  bool check_axes = true;     // search the other axes as well (margin small or refresh due)
  double max_cost_ratio = 0;  // accept the bracket's best only up to this cost / leaf cost
};

// What a build saw at one searched node.
struct SplitObservation {
  std::uint64_t path = 0;
  int depth = 0;
  int axis = 0;
  double fraction = 0;
  std::optional<double> axis_margin;  // set when all axes were searched
  std::optional<double> predicted;    // the fraction predicted for this axis, if any
  double cost_ratio = 0;              // split cost / leaf cost
};

class SplitPredictor {
 public:
  explicit SplitPredictor(const PredictorConfig& config = {}) : config_(config) {}

  const PredictorConfig& config() const { return config_; }
  // The prediction for the node at `path`, `depth` in the next build; thread safe while no
  // update runs.
  std::optional<SplitPrediction> predict(std::uint64_t path, int depth) const;
  // Ends a frame: feeds every observation to its node's filter, forgets nodes not seen.
  void update(std::span<const SplitObservation> observations);
  std::size_t tracked() const { return live_; }
  void clear();

 private:
  struct Track {
    std::uint64_t path = 0;
    int depth = 0, axis = 0;
    double margin = 0;       // axis margin at the last full search
    double cost_ratio = 0;   // split cost / leaf cost in the last frame
    int since_full = 0;      // frames since the last full search
    double error_power = 0;  // running mean square prediction error (Wiener's uncertainty)
    std::variant<KalmanFilter, WienerPredictor> filter;
    std::uint64_t frame = 0;
  };
  // Tracks in a vector, found through an open-addressing index on the path (a frame looks up
  // and updates one track per node, hundreds of thousands: a node-based map costs as much
  // as the build it saves). Tracks not seen in the last frame are dead and dropped in bulk.
  std::uint32_t find(std::uint64_t path) const;  // kNone when absent
  void rebuild_index();
  static constexpr std::uint32_t kNone = ~0u;
  PredictorConfig config_;
  std::vector<Track> tracks_;
  std::vector<std::uint64_t> keys_;  // 0 = empty slot
  std::vector<std::uint32_t> slots_;
  std::size_t live_ = 0;
  std::uint64_t frame_ = 0;
};

}  // namespace splitray

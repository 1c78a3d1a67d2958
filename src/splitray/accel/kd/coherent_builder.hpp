#pragma once
// Coherent kd rebuilds of an animation (issue #20): from the second frame on, the tree of a
// frame is made from the previous frame's tree and the split predictors' forecasts (paper
// 000's Kalman or Wiener filters) instead of from scratch. The builder keeps the previous
// tree's shape, moves its planes to their predicted positions, re-optimises the planes of
// large nodes locally, distributes the triangles down in one pass per node (no event lists,
// no full search) and rebuilds from scratch only the subtrees whose SAH cost drifted beyond
// a tolerance, so the tree's quality cannot decay over a long sequence.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>

#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/accel/predict/split_predictor.hpp"

namespace splitray {

// What one frame's build did. Node counts are of the finished tree (interior nodes and
// leaves); the parts' times are CPU milliseconds summed over threads (distribution: the
// walk's own time less its searches and rebuilds), the total is wall time.
struct CoherentFrameStats {
  bool from_scratch = false;          // the first frame, or a fallback (see reason)
  std::string reason;                 // why the frame was built from scratch ("" otherwise)
  std::size_t reused_nodes = 0;       // kept from the previous frame, plane moved as predicted
  std::size_t reoptimised_nodes = 0;  // kept, plane re-searched locally around the prediction
  std::size_t rebuilt_nodes = 0;      // made by the from-scratch builder this frame
  std::size_t rebuilt_subtrees = 0;   // subtrees rebuilt because their cost drifted
  double predict_ms = 0, distribute_ms = 0, search_ms = 0, rebuild_ms = 0, layout_ms = 0;
  double total_ms = 0;  // wall time of the whole frame, layout included
  double sah_cost = 0;  // of the finished tree (sah_cost.hpp), with the config's K_T and K_I
  // The filters' forecasts at the re-searched nodes: |searched - forecast| split position in
  // fractions of the cell (over `forecasts` nodes), and the root's split and forecast in world
  // coordinates (paper 000 Fig. 7).
  std::size_t forecasts = 0;
  double mean_error = 0, max_error = 0;
  int root_axis = -1;
  std::optional<double> root_actual, root_predicted;
};

// When a kept part of the tree is made afresh. The defaults keep the SAH cost within 1-4% of
// golden's from-scratch trees on horse collapse and MD2 faerie at K_T 15 and 70 (README);
// tighter tolerances rebuild more (at 0.05 more than half the tree every frame).
struct CoherentConfig {
  // A kept plane whose own SAH cost (its children costed as leaves, relative to the node's
  // leaf cost) grew by more than this share since it was chosen is decided afresh by golden,
  // before any work goes into its children.
  double split_tolerance = 0.2;
  // A kept subtree whose cost (relative to its leaf cost) grew by more than this share since
  // it was built is rebuilt: the safety net against slow decay and sudden jumps.
  double subtree_tolerance = 0.3;
  // Nodes of at least this many references re-search their plane around the filters'
  // forecast (paper 000, Algorithm 1) and feed the filters.
  std::size_t search_prims = 1024;
  // After a frame that rebuilt more than this share of its nodes, the next frame is built
  // from scratch: the kept shape's references have aged, and distributing into a tree that
  // is then mostly rebuilt costs more than building it afresh.
  double scratch_share = 0.4;
};

class KdCoherentBuilder {
 public:
  // `config.builder` is the from-scratch builder of the first frame and of rebuilt subtrees
  // (empty: golden; golden is the only one).
  KdCoherentBuilder(const BuildConfig& config, const PredictorConfig& predictor,
                    const CoherentConfig& coherent = {});
  ~KdCoherentBuilder();
  KdCoherentBuilder(KdCoherentBuilder&&) noexcept;
  KdCoherentBuilder& operator=(KdCoherentBuilder&&) noexcept;

  // The tree of the next frame. Throws Error when `triangles` is empty or its count differs
  // from the previous frame's.
  std::unique_ptr<KdAccel> next_frame(std::span<const Triangle> triangles,
                                      CoherentFrameStats& stats);
  // Forgets the previous frames: the next frame is built from scratch.
  void reset();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace splitray

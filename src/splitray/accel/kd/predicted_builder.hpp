#pragma once
// The kd build of frame k+1 of an animation, steered by the splits of frames 1..k (paper
// 000 §5, Algorithm 1). It is the `golden` builder, except at the nodes a SplitPredictor
// knows (same path from the root, same depth): there the golden-section/parabolic search
// starts at the predicted position inside a bracket as wide as the prediction's
// uncertainty, on the predicted axis only unless that axis won narrowly when last checked.
// Where no prediction exists, or the best split sits at the bracket's edge, the node falls
// back to golden's full search of all axes. The splits chosen are returned as observations
// for the predictor's update.
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "splitray/accel/kd/golden_search.hpp"
#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/accel/kd/kd_build.hpp"
#include "splitray/accel/predict/split_predictor.hpp"

namespace splitray {

// Paper 000's Algorithm 1 at one node, the one home of it (golden's event lists and the
// PrimRef nodes of predicted rebuilds both call it): the predicted axis is searched in the
// bracket the prediction's uncertainty spans, starting at the predicted position, by
// `search(axis, lo, hi, start)`, the builder's bracketed golden search. Its best split is
// accepted when it lies inside the bracket and costs at most max_cost_ratio times the leaf;
// otherwise the node falls back to the full search (and, when accepted, the other axes are
// searched as well if prediction.check_axes). For a prediction whose axis has extent > 0.
struct PredictedSearch {
  GoldenSearchResult result;
  bool accepted = false;
};
template <class BracketSearch>
PredictedSearch search_predicted(const SplitPrediction& prediction, const Aabb& cell,
                                 double leaf_cost, BracketSearch&& search) {
  const int a = prediction.axis;
  const double lo = cell.lo[a], extent = static_cast<double>(cell.hi[a]) - lo;
  const double center = lo + prediction.fraction * extent;
  const double half = prediction.half_width * extent;
  PredictedSearch out;
  out.result = search(a, static_cast<float>(center - half), static_cast<float>(center + half),
                      static_cast<float>(center));
  out.accepted = out.result.best.valid() && !out.result.at_bracket_edge &&
                 out.result.best.cost <= prediction.max_cost_ratio * leaf_cost;
  return out;
}

struct PredictedBuildStats {
  std::uint64_t cost_evals = 0;
  std::size_t searched_nodes = 0;   // nodes that ran a golden search (the others are small)
  std::size_t predicted_nodes = 0;  // of those, nodes whose predicted bracket held the split
  std::size_t fallbacks = 0;        // predictions abandoned: bracket edge or no valid split
  // |actual - predicted| split position in fractions of the node's cell, over the nodes with
  // a prediction whose axis the build kept.
  double mean_error = 0, max_error = 0;
  std::size_t errors = 0;
  // The root's split (world coordinates) and what was predicted for it, for paper Fig. 7.
  int root_axis = -1;
  std::optional<double> root_actual, root_predicted;
  std::vector<SplitObservation> observations;  // sorted by path
};

// Builds the tree of `triangles` in `cell`; `predictor` may be null (then the tree is
// golden's). Observations and statistics go to `stats`.
KdBuildResult build_kd_predicted(std::span<const Triangle> triangles, const Aabb& cell,
                                 const BuildConfig& config, const SplitPredictor* predictor,
                                 PredictedBuildStats& stats);

// The whole step of one frame as make_kd does it (bounds, build, flatten, KdAccel), then
// the predictor's update with this frame's splits.
std::unique_ptr<KdAccel> make_kd_predicted(std::span<const Triangle> triangles,
                                           const BuildConfig& config, SplitPredictor& predictor,
                                           PredictedBuildStats& stats);

}  // namespace splitray

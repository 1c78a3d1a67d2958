// The predicted kd builder: golden's recursion (golden_build.hpp) with Algorithm 1 of paper
// 000 at each searched node, and the statistics of a frame. Every decision depends only on
// the data and the predictor's state, so the tree is the same for any thread count.
#include "splitray/accel/kd/predicted_builder.hpp"

#include <algorithm>
#include <cmath>

#include "splitray/accel/kd/golden_build.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"

namespace splitray {

KdBuildResult build_kd_predicted(std::span<const Triangle> triangles, const Aabb& cell,
                                 const BuildConfig& config, const SplitPredictor* predictor,
                                 PredictedBuildStats& stats) {
  std::vector<GoldenNodeRecord> records;
  KdBuildResult result = build_kd_golden_steered(triangles, cell, config, predictor, &records);
  stats = PredictedBuildStats{};
  stats.cost_evals = result.cost_evals;
  stats.searched_nodes = records.size();
  double error_sum = 0;
  for (const GoldenNodeRecord& r : records) {
    stats.predicted_nodes += r.used_prediction;
    stats.fallbacks += r.fell_back;
    if (r.observation.predicted) {
      const double e = std::abs(r.observation.fraction - *r.observation.predicted);
      error_sum += e;
      stats.max_error = std::max(stats.max_error, e);
      ++stats.errors;
    }
  }
  if (stats.errors > 0) stats.mean_error = error_sum / static_cast<double>(stats.errors);
  if (!records.empty() && records.front().observation.path == kRootPath) {
    const SplitObservation& root = records.front().observation;
    const int a = root.axis;
    const double lo = cell.lo[a], extent = static_cast<double>(cell.hi[a]) - lo;
    stats.root_axis = a;
    stats.root_actual = lo + root.fraction * extent;
    if (predictor && root.predicted) stats.root_predicted = lo + *root.predicted * extent;
  }
  stats.observations.reserve(records.size());
  for (const GoldenNodeRecord& r : records) stats.observations.push_back(r.observation);
  return result;
}

std::unique_ptr<KdAccel> make_kd_predicted(std::span<const Triangle> triangles,
                                           const BuildConfig& config, SplitPredictor& predictor,
                                           PredictedBuildStats& stats) {
  if (triangles.empty()) throw Error("--accel kd", "no triangles to build on");
  BuildConfig resolved = config;
  resolved.builder = "golden+" + predictor_name(predictor.config().kind);
  ThreadLimit limit(resolved.threads);
  const Timer timer;
  Aabb bounds;
  for (const Triangle& t : triangles) bounds.extend(t.bounds());
  KdBuildResult built = build_kd_predicted(triangles, bounds, resolved, &predictor, stats);
  KdTree tree = take_kd_tree(built, bounds);
  predictor.update(stats.observations);
  return std::make_unique<KdAccel>(std::move(tree), triangles, resolved, built.cost_evals, timer);
}

}  // namespace splitray

// The predicted kd builder: golden_builder.cpp's recursion with Algorithm 1 of paper 000 at
// each searched node. Every decision depends only on the data and the predictor's state,
// so the tree is the same for any thread count; observations are sorted before use.
#include "splitray/accel/kd/predicted_builder.hpp"

#include <tbb/concurrent_vector.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "splitray/accel/kd/golden_events.hpp"
#include "splitray/accel/kd/golden_search.hpp"
#include "splitray/accel/kd/golden_small.hpp"
#include "splitray/accel/kd/kd_sah.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"

namespace splitray {

namespace {

// The same thresholds as golden_builder.cpp, so that without predictions the trees agree.
constexpr std::size_t kParallelSubtree = 2048;
constexpr std::size_t kParallelNode = 32768;
constexpr std::size_t kSmallPrims = 32;

struct Built {
  std::unique_ptr<KdBuildNode> node;
  std::uint64_t evals = 0;
};

struct NodeRecord {
  SplitObservation observation;
  std::optional<SplitPrediction> prediction;
  bool used_prediction = false, fell_back = false;
};

class PredictedBuilder {
 public:
  PredictedBuilder(std::span<const Triangle> triangles, const BuildConfig& config,
                   std::size_t prims, const SplitPredictor* predictor)
      : triangles_(triangles),
        predictor_(predictor),
        cost_(config),
        max_depth_(kd_max_depth(config, prims)),
        max_leaf_(static_cast<std::size_t>(std::max(config.max_leaf_prims, 0))) {}

  Built build_task(GoldenPrims& prims, const Aabb& cell, int depth, std::uint64_t path) const {
    if (prims.size() >= kParallelSubtree) return build(prims, cell, depth, path, nullptr, nullptr);
    Arenas& arenas = arenas_.local();
    const BumpArena::Mark mark = arenas.nodes.mark();
    Built built = build(prims, cell, depth, path, &arenas.nodes, &arenas.scratch);
    arenas.nodes.release(mark);
    return built;
  }

  tbb::concurrent_vector<NodeRecord>& records() const { return records_; }

 private:
  // Algorithm 1: the predicted axis in its bracket, else (or also) golden's full search.
  // Returns the chosen axis (-1: none) and fills `axes`, `record`.
  int choose_split(GoldenPrims& prims, const Aabb& cell, int depth, std::uint64_t path,
                   GoldenSearchResult (&axes)[3], NodeRecord& record, std::uint64_t& evals) const {
    const bool parallel = prims.size() >= kParallelNode;
    bool searched[3] = {false, false, false};
    const std::optional<SplitPrediction> prediction =
        predictor_ ? predictor_->predict(path, depth) : std::nullopt;
    record.prediction = prediction;
    if (prediction && cell.lo[prediction->axis] < cell.hi[prediction->axis]) {
      const int a = prediction->axis;
      const double lo = cell.lo[a], extent = static_cast<double>(cell.hi[a]) - lo;
      const double center = lo + prediction->fraction * extent;
      const double half = prediction->half_width * extent;
      GoldenSearchResult r = golden_search_axis(
          prims.axis_events(a), cell, a, cost_, static_cast<float>(center - half),
          static_cast<float>(center + half), static_cast<float>(center));
      evals += r.evals;
      const double leaf = cost_.leaf(prims.size());
      if (r.best.valid() && !r.at_bracket_edge &&
          r.best.cost <= prediction->max_cost_ratio * leaf) {
        axes[a] = r;
        searched[a] = true;
        record.used_prediction = true;
        if (!prediction->check_axes) return a;
      } else {
        record.fell_back = true;
      }
    }
    const auto search = [&](int axis) {
      if (!searched[axis] && cell.lo[axis] < cell.hi[axis])
        axes[axis] = golden_search_axis(prims.axis_events(axis), cell, axis, cost_, cell.lo[axis],
                                        cell.hi[axis]);
    };
    if (parallel)
      tbb::parallel_invoke([&] { search(0); }, [&] { search(1); }, [&] { search(2); });
    else
      for (int axis = 0; axis < 3; ++axis) search(axis);
    int axis = -1;
    for (int a = 0; a < 3; ++a) {
      if (!searched[a]) evals += axes[a].evals;
      if (axes[a].best.valid() && (axis < 0 || axes[a].best.cost < axes[axis].best.cost)) axis = a;
    }
    if (axis >= 0) {
      double second = std::numeric_limits<double>::infinity();
      for (int a = 0; a < 3; ++a)
        if (a != axis && axes[a].best.valid()) second = std::min(second, axes[a].best.cost);
      record.observation.axis_margin =
          std::isfinite(second) ? (second - axes[axis].best.cost) / axes[axis].best.cost : 1e9;
    }
    return axis;
  }

  Built build(GoldenPrims& prims, const Aabb& cell, int depth, std::uint64_t path, BumpArena* nodes,
              BumpArena* scratch) const {
    Built out;
    out.node = std::make_unique<KdBuildNode>();
    const std::size_t n = prims.size();
    const auto make_leaf = [&] {
      const auto ids = prims.ids();
      out.node->prims.assign(ids.begin(), ids.end());
      prims.release();
      return std::move(out);
    };
    if (n <= max_leaf_ || depth >= max_depth_ || !(cell.half_area() > 0)) return make_leaf();
    if (n <= kSmallPrims) return build_small(prims, cell, depth, nodes);

    GoldenSearchResult axes[3];
    NodeRecord record;
    const int axis = choose_split(prims, cell, depth, path, axes, record, out.evals);
    if (axis < 0 || !(axes[axis].best.cost < cost_.leaf(n))) return make_leaf();

    const SplitCandidate& split = axes[axis].best;
    {
      const double extent = static_cast<double>(cell.hi[axis]) - cell.lo[axis];
      record.observation.path = path;
      record.observation.depth = depth;
      record.observation.axis = axis;
      record.observation.fraction = (split.position - static_cast<double>(cell.lo[axis])) / extent;
      record.observation.cost_ratio = split.cost / cost_.leaf(n);
      if (record.prediction && record.prediction->axis == axis)
        record.observation.predicted = record.prediction->fraction;
      records_.push_back(record);
    }
    GoldenSplitOptions options;
    options.parallel = n >= kParallelNode;
    options.nodes = nodes;
    options.scratch = scratch;
    options.events_from = depth + 1 >= max_depth_ ? std::numeric_limits<std::size_t>::max()
                                                  : std::max(max_leaf_, kSmallPrims);
    const BumpArena::Mark mark = nodes ? nodes->mark() : BumpArena::Mark{};
    GoldenPrims below, above;
    split_golden_prims(prims, triangles_, cell, axis, split.position, split.planar_below, below,
                       above, options);
    Aabb below_cell = cell, above_cell = cell;
    below_cell.hi[axis] = split.position;
    above_cell.lo[axis] = split.position;
    out.node->axis = axis;
    out.node->split = split.position;
    const std::uint64_t below_path = path_child(path, false), above_path = path_child(path, true);
    Built b, a;
    if (!nodes) {
      tbb::parallel_invoke([&] { b = build_task(below, below_cell, depth + 1, below_path); },
                           [&] { a = build_task(above, above_cell, depth + 1, above_path); });
    } else {
      b = build(below, below_cell, depth + 1, below_path, nodes, scratch);
      a = build(above, above_cell, depth + 1, above_path, nodes, scratch);
      nodes->release(mark);
    }
    out.node->below = std::move(b.node);
    out.node->above = std::move(a.node);
    out.evals += b.evals + a.evals;
    return out;
  }

  Built build_small(GoldenPrims& prims, const Aabb& cell, int depth, BumpArena* nodes) const {
    BumpArena local;
    BumpArena& arena = nodes ? *nodes : local;
    const BumpArena::Mark mark = arena.mark();
    const std::size_t n = prims.size();
    PrimRef* refs = arena.allocate<PrimRef>(n);
    for (std::size_t i = 0; i < n; ++i) refs[i] = {prims.bounds()[i], prims.ids()[i]};
    prims.release();
    Built out;
    out.node = build_small_subtree({triangles_, cost_, max_depth_, max_leaf_}, {refs, n}, cell,
                                   depth, arena, out.evals);
    arena.release(mark);
    return out;
  }

  struct Arenas {
    BumpArena nodes, scratch;
  };
  std::span<const Triangle> triangles_;
  const SplitPredictor* predictor_;
  mutable tbb::enumerable_thread_specific<Arenas> arenas_;
  mutable tbb::concurrent_vector<NodeRecord> records_;
  KdSplitCost cost_;
  int max_depth_;
  std::size_t max_leaf_;
};

}  // namespace

KdBuildResult build_kd_predicted(std::span<const Triangle> triangles, const Aabb& cell,
                                 const BuildConfig& config, const SplitPredictor* predictor,
                                 PredictedBuildStats& stats) {
  GoldenPrims prims = make_golden_prims(triangles, cell, triangles.size() >= kParallelNode);
  const PredictedBuilder builder(triangles, config, prims.size(), predictor);
  Built built = builder.build_task(prims, cell, 0, kRootPath);
  KdBuildResult result;
  result.root = std::move(built.node);
  result.cost_evals = built.evals;

  std::vector<NodeRecord> records(builder.records().begin(), builder.records().end());
  std::sort(records.begin(), records.end(), [](const NodeRecord& a, const NodeRecord& b) {
    return a.observation.path < b.observation.path;
  });
  stats = PredictedBuildStats{};
  stats.cost_evals = result.cost_evals;
  stats.searched_nodes = records.size();
  double error_sum = 0;
  for (const NodeRecord& r : records) {
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
  for (const NodeRecord& r : records) stats.observations.push_back(r.observation);
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
  KdTree tree = flatten_kd(*built.root, bounds);
  built.root.reset();
  predictor.update(stats.observations);
  return std::make_unique<KdAccel>(std::move(tree), triangles, resolved, built.cost_evals, timer);
}

}  // namespace splitray

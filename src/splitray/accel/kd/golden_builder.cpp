// The `golden` kd builder (paper 000 §5, after Hussain & Grahn 2007): per node and axis
// the SAH minimum over the split position is searched by golden-section steps combined
// with parabolic interpolation (Brent), the primitive counts at each probe coming from
// binary searches in the node's sorted event lists (golden_search.hpp). The best axis wins;
// a node becomes a leaf by the rules shared with every kd builder (kd_sah.hpp).
//
// Where a search does not pay, the exact answer is cheaper: an axis with at most 128 events
// is swept event by event (golden_search.hpp), and a node of at most 64 primitives (so at
// most 128 events an axis, which would be swept anyway) is finished by golden_small (every
// bound costed, its counts by vector compares), so the search runs on the upper levels,
// where nodes are large.
//
// Cost evaluations (counted in KdBuildResult::cost_evals), measured on the horse (16.8k
// triangles) and the dragon (100k): an axis searched by golden section takes 17.5 on
// average (2 empty-space cuts + 8 coarse samples + about 7 Brent steps and snaps to
// events); a node of more than 32 primitives about 80 (three axes, the smaller ones swept);
// over all nodes of the tree, small ones included, 9.8 (horse) and 9.1 (dragon) per node,
// against 13.1 and 12.5 for the exact sweep of `sah`. Tree SAH cost: 1.000x and 1.003x sah's.
//
// Subtrees of large nodes are built in parallel, and large nodes search their three axes
// and split their event lists in parallel; every decision depends only on the data, so the
// tree is the same for any thread count. Nodes go straight into compact KdNode chunks
// (kd_emit.hpp), no pointer tree, and per-node arrays live on bump arenas.
//
// Predicted rebuilds (predicted_builder.hpp) run this same recursion with a SplitPredictor:
// a node it decides by the prediction alone hands its children plain PrimRef arrays (no
// sorted lists to keep), which search their predicted bracket in one pass over their
// bounds; a node whose prediction fails gets its sorted lists made on the spot.

#include <algorithm>
#include <cmath>
#include <limits>

#include "splitray/accel/kd/golden_build.hpp"
#include "splitray/accel/kd/golden_events.hpp"
#include "splitray/accel/kd/golden_search.hpp"
#include "splitray/accel/kd/golden_small.hpp"
#include "splitray/accel/kd/kd_emit.hpp"
#include "splitray/accel/kd/kd_sah.hpp"
#include "splitray/accel/kd/predicted_builder.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

// One pass collects the events inside the bracket and counts the primitives wholly on
// either side of it, then golden_search_axis searches the bracket from `start`.
GoldenSearchResult search_bracket_refs(std::span<const PrimRef> prims, const Aabb& cell, int axis,
                                       const KdSplitCost& cost, float lo, float hi, float start,
                                       BumpArena& scratch) {
  lo = std::max(lo, cell.lo[axis]);
  hi = std::min(hi, cell.hi[axis]);
  if (!(lo < hi)) return {};
  const BumpArena::Mark mark = scratch.mark();
  const std::size_t n = prims.size();
  float* starts = scratch.allocate<float>(n);
  float* ends = scratch.allocate<float>(n);
  float* planes = scratch.allocate<float>(n);
  std::size_t n_starts = 0, n_ends = 0, n_planes = 0, before = 0, after = 0;
  for (const PrimRef& r : prims) {
    const float l = r.bounds.lo[axis], h = r.bounds.hi[axis];
    if (l == h) {
      if (l < lo)
        ++before;
      else if (l > hi)
        ++after;
      else
        planes[n_planes++] = l;
      continue;
    }
    if (l < lo)
      ++before;
    else if (l <= hi)
      starts[n_starts++] = l;
    if (h > hi)
      ++after;
    else if (h >= lo)
      ends[n_ends++] = h;
  }
  std::sort(starts, starts + n_starts);
  std::sort(ends, ends + n_ends);
  std::sort(planes, planes + n_planes);
  AxisEvents events{{starts, n_starts}, {ends, n_ends}, {planes, n_planes}};
  events.below_before = before;
  events.above_after = after;
  GoldenSearchResult r = golden_search_axis(events, cell, axis, cost, lo, hi, start);
  scratch.release(mark);
  return r;
}

namespace {

constexpr std::size_t kParallelSubtree = 2048;  // prims above which children build in parallel
constexpr std::size_t kParallelNode = 32768;    // prims above which one node's work is parallel
constexpr std::size_t kSmallPrims = 64;         // nodes this small finish on PrimRef arrays
static_assert(kSmallPrims <= kSmallSplitMaxPrims);

// The records of a subtree in depth-first order: the node's own (and its sequential
// subtree's), then the parts of its children built as tasks.
struct RecordPart {
  std::vector<GoldenNodeRecord> records;
  std::unique_ptr<RecordPart> below, above;

  void flatten(std::vector<GoldenNodeRecord>& out) {
    out.insert(out.end(), records.begin(), records.end());
    if (below) below->flatten(out);
    if (above) above->flatten(out);
  }
};

class GoldenBuilder {
 public:
  GoldenBuilder(std::span<const Triangle> triangles, const BuildConfig& config, std::size_t prims,
                const SplitPredictor* predictor, bool record)
      : triangles_(triangles),
        predictor_(predictor),
        record_(record),
        cost_(config),
        max_depth_(kd_max_depth(config, prims)),
        max_leaf_(static_cast<std::size_t>(std::max(config.max_leaf_prims, 0))) {}

  // A subtree: large ones keep their arrays on the heap and build their children as tasks,
  // small ones run sequentially on bump arenas into one chunk of nodes.
  std::unique_ptr<KdPartial> build_task(GoldenPrims& prims, const Aabb& cell, int depth,
                                        std::uint64_t path, std::uint64_t& evals,
                                        RecordPart* rec) const {
    auto part = std::make_unique<KdPartial>();
    if (prims.size() < kParallelSubtree) {
      // Small subtrees never wait for other tasks, so one pair of arenas per thread serves all.
      Arenas& arenas = arenas_.local();
      const BumpArena::Mark mark = arenas.nodes.mark();
      build_seq(prims, cell, depth, path, arenas.nodes, arenas.scratch, part->chunk, evals, rec);
      arenas.nodes.release(mark);
      return part;
    }
    GoldenSearchResult axes[3];
    const int axis = decide(prims, cell, depth, path, axes, evals, rec).axis;
    if (axis < 0) {
      part->chunk.add_leaf(prims.ids());
      prims.release();
      return part;
    }
    const SplitCandidate split = axes[axis].best;
    GoldenPrims below, above;
    split_golden_prims(prims, triangles_, cell, axis, split.position, split.planar_below, below,
                       above, split_options(prims.size(), depth, nullptr, nullptr));
    // (A pair, not a structured binding: the lambdas below capture the cells.)
    const std::pair<Aabb, Aabb> cells = child_cells(cell, axis, split.position);
    const Aabb &below_cell = cells.first, &above_cell = cells.second;
    part->axis = axis;
    part->split = split.position;
    std::uint64_t eb = 0, ea = 0;
    if (rec) {
      rec->below = std::make_unique<RecordPart>();
      rec->above = std::make_unique<RecordPart>();
    }
    parallel_invoke(
        [&] {
          part->below = build_task(below, below_cell, depth + 1, path_child(path, false), eb,
                                   rec ? rec->below.get() : nullptr);
        },
        [&] {
          part->above = build_task(above, above_cell, depth + 1, path_child(path, true), ea,
                                   rec ? rec->above.get() : nullptr);
        });
    evals += eb + ea;
    return part;
  }

  // The golden subtree of a node given as PrimRefs, sequentially, appended to `out`.
  void build_refs_into(std::span<const PrimRef> prims, const Aabb& cell, int depth, KdChunk& out,
                       std::uint64_t& evals) const {
    Arenas& arenas = arenas_.local();
    const BumpArena::Mark mark = arenas.nodes.mark();
    build_refs(prims, cell, depth, 0, arenas.nodes, arenas.scratch, out, evals, nullptr);
    arenas.nodes.release(mark);
  }

 private:
  struct Decision {
    int axis = -1;           // -1: a leaf
    bool predicted = false;  // decided by the prediction alone
  };

  // A node with sorted lists, sequentially.
  void build_seq(GoldenPrims& prims, const Aabb& cell, int depth, std::uint64_t path,
                 BumpArena& nodes, BumpArena& scratch, KdChunk& out, std::uint64_t& evals,
                 RecordPart* rec) const {
    const std::size_t n = prims.size();
    if (n > max_leaf_ && depth < max_depth_ && cell.half_area() > 0 && n <= kSmallPrims) {
      const BumpArena::Mark mark = nodes.mark();
      const std::span<PrimRef> refs = to_refs(prims, nodes);
      build_refs(refs, cell, depth, path, nodes, scratch, out, evals, rec);
      nodes.release(mark);
      return;
    }
    GoldenSearchResult axes[3];
    const Decision d = decide(prims, cell, depth, path, axes, evals, rec);
    if (d.axis < 0) {
      out.add_leaf(prims.ids());
      prims.release();
      return;
    }
    const int axis = d.axis;
    const SplitCandidate split = axes[axis].best;
    const BumpArena::Mark mark = nodes.mark();
    const auto [below_cell, above_cell] = child_cells(cell, axis, split.position);
    const std::size_t index = out.open_interior();
    if (d.predicted) {
      // A node the prediction decided: its children will most likely be predicted too and
      // need no sorted lists, so they get plain PrimRef arrays.
      const std::span<PrimRef> refs = to_refs(prims, nodes);
      BinnedSplit b;
      b.axis = axis;
      b.position = split.position;
      b.n_below = split.n_below;
      b.n_above = split.n_above;
      b.planar_below = split.planar_below;
      const std::span<PrimRef> below(nodes.allocate<PrimRef>(b.n_below), b.n_below);
      const std::span<PrimRef> above(nodes.allocate<PrimRef>(b.n_above), b.n_above);
      Aabb below_content, above_content;
      partition_binned(refs, triangles_, cell, b, below, above, below_content, above_content,
                       false);
      build_refs(below, below_cell, depth + 1, path_child(path, false), nodes, scratch, out, evals,
                 rec);
      out.set_interior(index, axis, split.position);
      build_refs(above, above_cell, depth + 1, path_child(path, true), nodes, scratch, out, evals,
                 rec);
    } else {
      GoldenPrims below, above;
      split_golden_prims(prims, triangles_, cell, axis, split.position, split.planar_below, below,
                         above, split_options(n, depth, &nodes, &scratch));
      build_seq(below, below_cell, depth + 1, path_child(path, false), nodes, scratch, out, evals,
                rec);
      out.set_interior(index, axis, split.position);
      build_seq(above, above_cell, depth + 1, path_child(path, true), nodes, scratch, out, evals,
                rec);
    }
    nodes.release(mark);
  }

  // A node kept as PrimRefs: small nodes (exact sweep on the spot) and, in predicted
  // rebuilds, nodes under a predicted one. A large node the prediction cannot decide gets
  // its sorted lists made on the spot and continues as golden's.
  void build_refs(std::span<const PrimRef> prims, const Aabb& cell, int depth, std::uint64_t path,
                  BumpArena& nodes, BumpArena& scratch, KdChunk& out, std::uint64_t& evals,
                  RecordPart* rec) const {
    const std::size_t n = prims.size();
    if (n <= max_leaf_ || depth >= max_depth_ || !(cell.half_area() > 0)) {
      add_leaf(prims, out);
      return;
    }
    // Small nodes are neither predicted nor recorded: deep in the tree a path's content
    // changes from frame to frame, so few predictions there hold, and tracking them cost
    // more than they saved (measured on anim_horse_collapse).
    const bool steered = n > kSmallPrims;
    const std::optional<SplitPrediction> prediction =
        predictor_ && steered ? predictor_->predict(path, depth) : std::nullopt;
    GoldenNodeRecord record;
    record.prediction = prediction;
    BinnedSplit split;
    bool decided = false;
    if (prediction && cell.lo[prediction->axis] < cell.hi[prediction->axis]) {
      const int a = prediction->axis;
      const PredictedSearch p = search_predicted(
          *prediction, cell, cost_.leaf(n), [&](int axis, float lo, float hi, float start) {
            return search_bracket_refs(prims, cell, axis, cost_, lo, hi, start, scratch);
          });
      const GoldenSearchResult& r = p.result;
      evals += r.evals;
      if (p.accepted) {
        record.used_prediction = true;
        if (!prediction->check_axes) {
          split.axis = a;
          split.position = r.best.position;
          split.cost = r.best.cost;
          split.n_below = r.best.n_below;
          split.n_above = r.best.n_above;
          split.planar_below = r.best.planar_below;
          decided = true;
        }
      } else {
        record.fell_back = true;
      }
    }
    if (!decided && n > kSmallPrims) {
      // Golden's full search needs the sorted lists: made here, and the node goes on as
      // golden's (which asks for the prediction again and records the node).
      const BumpArena::Mark mark = nodes.mark();
      GoldenPrims sorted = make_golden_prims(prims, &nodes);
      build_seq(sorted, cell, depth, path, nodes, scratch, out, evals, rec);
      nodes.release(mark);
      return;
    }
    std::optional<double> margin;
    if (!decided) {
      double axis_costs[3];
      split = find_small_split(prims, cell, cost_, rec && steered ? axis_costs : nullptr);
      evals += split.evals;
      if (rec && steered && split.axis >= 0) {
        double second = std::numeric_limits<double>::infinity();
        for (int a = 0; a < 3; ++a)
          if (a != split.axis) second = std::min(second, axis_costs[a]);
        margin = std::isfinite(second) ? (second - split.cost) / split.cost : 1e9;
      }
    }
    if (split.axis < 0 || !(split.cost < cost_.leaf(n))) {
      add_leaf(prims, out);
      return;
    }
    if (rec && steered) {
      record.observation.axis_margin = margin;
      fill_record(record, path, depth, split.axis, split.position, split.cost, n, cell);
      rec->records.push_back(record);
    }
    const BumpArena::Mark mark = nodes.mark();
    const std::span<PrimRef> below(nodes.allocate<PrimRef>(split.n_below), split.n_below);
    const std::span<PrimRef> above(nodes.allocate<PrimRef>(split.n_above), split.n_above);
    Aabb below_content, above_content;
    partition_binned(prims, triangles_, cell, split, below, above, below_content, above_content,
                     false);
    const auto [below_cell, above_cell] = child_cells(cell, split.axis, split.position);
    const std::size_t index = out.open_interior();
    build_refs(below, below_cell, depth + 1, path_child(path, false), nodes, scratch, out, evals,
               rec);
    out.set_interior(index, split.axis, split.position);
    build_refs(above, above_cell, depth + 1, path_child(path, true), nodes, scratch, out, evals,
               rec);
    nodes.release(mark);
  }

  // The split axis of a node (-1: a leaf), its best split in axes[axis]. Golden's full search
  // of every axis, or with a prediction paper 000's Algorithm 1: the predicted axis in its
  // bracket, then the other axes too when the prediction failed or is due for a check.
  Decision decide(const GoldenPrims& prims, const Aabb& cell, int depth, std::uint64_t path,
                  GoldenSearchResult (&axes)[3], std::uint64_t& evals, RecordPart* rec) const {
    const std::size_t n = prims.size();
    if (n <= max_leaf_ || depth >= max_depth_ || !(cell.half_area() > 0)) return {};
    const bool parallel = n >= kParallelNode;
    bool searched[3] = {false, false, false};
    GoldenNodeRecord record;
    const std::optional<SplitPrediction> prediction =
        predictor_ ? predictor_->predict(path, depth) : std::nullopt;
    record.prediction = prediction;
    bool done = false;
    if (prediction && cell.lo[prediction->axis] < cell.hi[prediction->axis]) {
      const int a = prediction->axis;
      const PredictedSearch p = search_predicted(
          *prediction, cell, cost_.leaf(n), [&](int axis, float lo, float hi, float start) {
            return golden_search_axis(prims.axis_events(axis), cell, axis, cost_, lo, hi, start);
          });
      evals += p.result.evals;
      if (p.accepted) {
        axes[a] = p.result;
        searched[a] = true;
        record.used_prediction = true;
        done = !prediction->check_axes;
      } else {
        record.fell_back = true;
      }
    }
    if (!done) {
      const auto search = [&](int axis) {
        if (!searched[axis] && cell.lo[axis] < cell.hi[axis])
          axes[axis] = golden_search_axis(prims.axis_events(axis), cell, axis, cost_, cell.lo[axis],
                                          cell.hi[axis]);
      };
      if (parallel)
        parallel_invoke([&] { search(0); }, [&] { search(1); }, [&] { search(2); });
      else
        for (int axis = 0; axis < 3; ++axis) search(axis);
    }
    // The best axis (ties: the lower axis).
    int axis = -1;
    for (int a = 0; a < 3; ++a) {
      if (!searched[a]) evals += axes[a].evals;
      if (axes[a].best.valid() && (axis < 0 || axes[a].best.cost < axes[axis].best.cost)) axis = a;
    }
    if (axis < 0 || !(axes[axis].best.cost < cost_.leaf(n))) return {};
    if (rec) {
      if (!done) {
        double second = std::numeric_limits<double>::infinity();
        for (int a = 0; a < 3; ++a)
          if (a != axis && axes[a].best.valid()) second = std::min(second, axes[a].best.cost);
        record.observation.axis_margin =
            std::isfinite(second) ? (second - axes[axis].best.cost) / axes[axis].best.cost : 1e9;
      }
      const SplitCandidate& split = axes[axis].best;
      fill_record(record, path, depth, axis, split.position, split.cost, n, cell);
      rec->records.push_back(record);
    }
    return {axis, done};
  }

  void fill_record(GoldenNodeRecord& record, std::uint64_t path, int depth, int axis,
                   float position, double cost, std::size_t n, const Aabb& cell) const {
    const double extent = static_cast<double>(cell.hi[axis]) - cell.lo[axis];
    record.observation.path = path;
    record.observation.depth = depth;
    record.observation.axis = axis;
    record.observation.fraction = (position - static_cast<double>(cell.lo[axis])) / extent;
    record.observation.cost_ratio = cost / cost_.leaf(n);
    if (record.prediction && record.prediction->axis == axis)
      record.observation.predicted = record.prediction->fraction;
  }

  GoldenSplitOptions split_options(std::size_t n, int depth, BumpArena* nodes,
                                   BumpArena* scratch) const {
    GoldenSplitOptions options;
    options.parallel = n >= kParallelNode;
    options.nodes = nodes;
    options.scratch = scratch;
    // Children at the depth limit or small enough become leaves: they need no event lists.
    options.events_from = depth + 1 >= max_depth_ ? std::numeric_limits<std::size_t>::max()
                                                  : std::max(max_leaf_, kSmallPrims);
    return options;
  }

  static std::pair<Aabb, Aabb> child_cells(const Aabb& cell, int axis, float position) {
    Aabb below = cell, above = cell;
    below.hi[axis] = position;
    above.lo[axis] = position;
    return {below, above};
  }

  static std::span<PrimRef> to_refs(GoldenPrims& prims, BumpArena& arena) {
    const std::size_t n = prims.size();
    PrimRef* refs = arena.allocate<PrimRef>(n);
    for (std::size_t i = 0; i < n; ++i) refs[i] = {prims.bounds()[i], prims.ids()[i]};
    prims.release();
    return {refs, n};
  }

  static void add_leaf(std::span<const PrimRef> prims, KdChunk& out) {
    out.nodes.push_back(KdNode::leaf(static_cast<std::uint32_t>(out.prims.size()),
                                     static_cast<std::uint32_t>(prims.size())));
    for (const PrimRef& r : prims) out.prims.push_back(r.id);
  }

  struct Arenas {
    BumpArena nodes, scratch;
  };
  std::span<const Triangle> triangles_;
  const SplitPredictor* predictor_;
  bool record_;
  mutable ThreadLocal<Arenas> arenas_;
  KdSplitCost cost_;
  int max_depth_;
  std::size_t max_leaf_;
};

}  // namespace

KdBuildResult build_kd_golden_steered(std::span<const Triangle> triangles, const Aabb& cell,
                                      const BuildConfig& config, const SplitPredictor* predictor,
                                      std::vector<GoldenNodeRecord>* records) {
  GoldenPrims prims = make_golden_prims(triangles, cell, triangles.size() >= kParallelNode);
  const GoldenBuilder builder(triangles, config, prims.size(), predictor, records != nullptr);
  KdBuildResult result;
  RecordPart rec;
  std::unique_ptr<KdPartial> top =
      builder.build_task(prims, cell, 0, kRootPath, result.cost_evals, records ? &rec : nullptr);
  result.tree = assemble_kd(*top, cell);
  if (records) {
    records->clear();
    rec.flatten(*records);
  }
  return result;
}

std::uint64_t build_kd_golden_refs(std::span<const PrimRef> prims,
                                   std::span<const Triangle> triangles, const Aabb& cell, int depth,
                                   std::size_t tree_prims, const BuildConfig& config,
                                   KdChunk& out) {
  const GoldenBuilder builder(triangles, config, tree_prims, nullptr, false);
  std::uint64_t evals = 0;
  builder.build_refs_into(prims, cell, depth, out, evals);
  return evals;
}

KdBuildResult build_kd_golden(std::span<const Triangle> triangles, const Aabb& cell,
                              const BuildConfig& config) {
  return build_kd_golden_steered(triangles, cell, config, nullptr, nullptr);
}

}  // namespace splitray

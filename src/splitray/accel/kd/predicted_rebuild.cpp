#include "splitray/accel/kd/predicted_rebuild.hpp"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <memory>
#include <atomic>
#include <cstdio>
#include <cstdlib>

#include "splitray/accel/kd/binned_arena.hpp"
#include "splitray/accel/kd/binned_split.hpp"
#include "splitray/accel/kd/golden_search.hpp"
#include "splitray/accel/kd/golden_small.hpp"
#include "splitray/accel/kd/kd_emit.hpp"
#include "splitray/accel/kd/kd_sah.hpp"

namespace splitray {

namespace {

constexpr std::size_t kParallelSubtree = 2048;  // prims above which children build in parallel
constexpr std::size_t kParallelNode = 32768;    // prims above which a partition is parallel
constexpr std::size_t kTracked = 32;            // nodes above this size have filters (as golden)
constexpr std::uint32_t kNoShape = ~0u;         // a node whose path the last tree lacks

static const int kMode = std::getenv("MODE") ? std::atoi(std::getenv("MODE")) : 0;
static const std::size_t kHintMax = std::getenv("HINTMAX") ? std::atoi(std::getenv("HINTMAX")) : 1000000000;
constexpr double kInfinity = std::numeric_limits<double>::infinity();

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

// The SAH minimum on `axis` within [lo, hi] of a node's primitives: one pass collects the
// events inside the bracket and counts the primitives wholly on either side of it, then
// golden_search_axis searches the bracket from `start`.
GoldenSearchResult search_bracket(std::span<const PrimRef> prims, const Aabb& cell, int axis,
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

// A float as an unsigned key of the same order (-0 made +0 first), as in golden_small.
std::uint32_t order_key(float f) {
  const std::uint32_t u = std::bit_cast<std::uint32_t>(f + 0.0f);
  return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}
float from_key(std::uint32_t k) {
  return std::bit_cast<float>((k & 0x80000000u) ? (k & 0x7fffffffu) : ~k);
}
enum : std::uint64_t { kEnd = 0, kPlane = 1, kStart = 2 };  // sweep order at one position

struct BracketSweep {
  BinnedSplit split;     // axis -1: no candidate in the bracket
  bool at_edge = false;  // the best is the bracket's first or last candidate, not at the cell's face
};

// find_small_split's exact sweep on one axis, restricted to the event positions in [lo, hi]:
// one pass over the bounds counts the primitives that start or end before the bracket and
// collects the events inside it, so only those few are sorted.
BracketSweep sweep_bracket(std::span<const PrimRef> prims, const Aabb& cell, int axis,
                           const KdSplitCost& cost, float lo, float hi, BumpArena& scratch) {
  BracketSweep out;
  out.split.cost = kInfinity;
  const float cell_lo = cell.lo[axis], cell_hi = cell.hi[axis];
  lo = std::max(lo, cell_lo);
  hi = std::min(hi, cell_hi);
  if (!(lo < hi)) return out;
  const BumpArena::Mark mark = scratch.mark();
  const std::size_t n = prims.size();
  std::uint64_t* keys = scratch.allocate<std::uint64_t>(2 * n);
  std::size_t m = 0, below = 0, ended = 0;
  for (const PrimRef& r : prims) {
    const float l = r.bounds.lo[axis], h = r.bounds.hi[axis];
    if (l == h) {
      if (l < lo)
        ++below, ++ended;
      else if (l <= hi)
        keys[m++] = (std::uint64_t{order_key(l)} << 2) | kPlane;
      continue;
    }
    if (l < lo)
      ++below;
    else if (l <= hi)
      keys[m++] = (std::uint64_t{order_key(l)} << 2) | kStart;
    if (h < lo)
      ++ended;
    else if (h <= hi)
      keys[m++] = (std::uint64_t{order_key(h)} << 2) | kEnd;
  }
  std::sort(keys, keys + m);
  const KdAxisCost axis_cost(cost, cell, axis);
  BinnedSplit& best = out.split;
  std::size_t above = n - ended;
  bool first = true, best_first = false, best_last = false;
  for (std::size_t i = 0; i < m;) {
    const std::uint64_t at = keys[i] >> 2;
    std::size_t counts[3] = {0, 0, 0};
    for (; i < m && (keys[i] >> 2) == at; ++i) ++counts[keys[i] & 3];
    const std::size_t planar = counts[kPlane];
    above -= counts[kEnd] + planar;
    const float p = from_key(static_cast<std::uint32_t>(at));
    if (p > cell_lo && p < cell_hi) {
      bool improved = false;
      double c = axis_cost(p, below + planar, above);
      ++best.evals;
      if (c < best.cost) {
        best.cost = c, best.position = p, best.n_below = below + planar, best.n_above = above;
        best.planar_below = improved = true;
      }
      if (planar > 0) {
        c = axis_cost(p, below, above + planar);
        ++best.evals;
        if (c < best.cost) {
          best.cost = c, best.position = p, best.n_below = below, best.n_above = above + planar;
          best.planar_below = false;
          improved = true;
        }
      }
      if (improved) best_first = first;
      best_last = improved;
      first = false;
    }
    below += counts[kStart] + planar;
  }
  scratch.release(mark);
  if (best.cost < kInfinity) best.axis = axis;
  out.at_edge = (best_first && lo > cell_lo) || (best_last && hi < cell_hi);
  return out;
}

// A fixed pseudo-random phase per path, so that the refreshes of a frame spread over the tree.
std::uint64_t path_phase(std::uint64_t path) {
  path ^= path >> 31;
  path *= 0x9e3779b97f4a7c15ull;
  return path >> 40;
}

class RebuildBuilder {
 public:
  RebuildBuilder(std::span<const Triangle> triangles, const BuildConfig& config, std::size_t prims,
                 const SplitPredictor& predictor)
      : triangles_(triangles),
        predictor_(predictor),
        shape_(predictor.shape()),
        frame_(predictor.frame()),
        refresh_(static_cast<std::uint64_t>(std::max(predictor.config().refresh_frames, 1))),
        shape_half_width_(predictor.config().shape_half_width),
        cost_(config),
        max_depth_(kd_max_depth(config, prims)),
        max_leaf_(static_cast<std::size_t>(std::max(config.max_leaf_prims, 0))) {}

  // A subtree: large ones keep their arrays on the heap and build their children as tasks,
  // small ones run sequentially on bump arenas into one chunk of nodes.
  std::unique_ptr<KdPartial> build_task(std::vector<PrimRef>& prims, const Aabb& cell, int depth,
                                        std::uint64_t path, std::uint32_t shape,
                                        std::uint64_t& evals, RecordPart& rec) const {
    auto part = std::make_unique<KdPartial>();
    Arenas& arenas = arenas_.local();
    if (prims.size() < kParallelSubtree) {
      // Small subtrees never wait for other tasks, so one pair of arenas per thread serves all.
      const BumpArena::Mark mark = arenas.nodes.mark();
      build_seq(prims, cell, depth, path, shape, arenas.nodes, arenas.scratch, part->chunk, evals,
                rec.records);
      arenas.nodes.release(mark);
      return part;
    }
    const BinnedSplit split = decide(prims, cell, depth, path, shape, arenas.scratch, evals,
                                     rec.records);
    if (split.axis < 0) {
      add_leaf(prims, part->chunk);
      return part;
    }
    std::vector<PrimRef> below(split.n_below), above(split.n_above);
    Aabb below_content, above_content;
    partition_binned(prims, triangles_, cell, split, below, above, below_content, above_content,
                     prims.size() >= kParallelNode);
    std::vector<PrimRef>().swap(prims);
    const auto [below_cell, above_cell] = child_cells(cell, split.axis, split.position);
    const auto [below_shape, above_shape] = child_shapes(shape, below_cell, above_cell);
    part->axis = split.axis;
    part->split = split.position;
    rec.below = std::make_unique<RecordPart>();
    rec.above = std::make_unique<RecordPart>();
    std::uint64_t eb = 0, ea = 0;
    tbb::parallel_invoke(
        [&] {
          part->below = build_task(below, below_cell, depth + 1, path_child(path, false),
                                   below_shape, eb, *rec.below);
        },
        [&] {
          part->above = build_task(above, above_cell, depth + 1, path_child(path, true),
                                   above_shape, ea, *rec.above);
        });
    evals += eb + ea;
    return part;
  }

 private:
  void build_seq(std::span<const PrimRef> prims, const Aabb& cell, int depth, std::uint64_t path,
                 std::uint32_t shape, BumpArena& nodes, BumpArena& scratch, KdChunk& out,
                 std::uint64_t& evals, std::vector<GoldenNodeRecord>& records) const {
    const BinnedSplit split = decide(prims, cell, depth, path, shape, scratch, evals, records);
    if (split.axis < 0) {
      add_leaf(prims, out);
      return;
    }
    const BumpArena::Mark mark = nodes.mark();
    const std::span<PrimRef> below(nodes.allocate<PrimRef>(split.n_below), split.n_below);
    const std::span<PrimRef> above(nodes.allocate<PrimRef>(split.n_above), split.n_above);
    Aabb below_content, above_content;
    partition_binned(prims, triangles_, cell, split, below, above, below_content, above_content,
                     false);
    const auto [below_cell, above_cell] = child_cells(cell, split.axis, split.position);
    const auto [below_shape, above_shape] = child_shapes(shape, below_cell, above_cell);
    const std::size_t index = out.open_interior();
    build_seq(below, below_cell, depth + 1, path_child(path, false), below_shape, nodes, scratch,
              out, evals, records);
    out.set_interior(index, split.axis, split.position);
    build_seq(above, above_cell, depth + 1, path_child(path, true), above_shape, nodes, scratch,
              out, evals, records);
    nodes.release(mark);
  }

  // The split of a node (axis -1: a leaf).
  BinnedSplit decide(std::span<const PrimRef> prims, const Aabb& cell, int depth,
                     std::uint64_t path, std::uint32_t shape, BumpArena& scratch,
                     std::uint64_t& evals, std::vector<GoldenNodeRecord>& records) const {
    BinnedSplit best;
    const std::size_t n = prims.size();
    if (n <= max_leaf_ || depth >= max_depth_ || !(cell.half_area() > 0)) return best;
    const bool tracked = n > kTracked;
    const bool refresh = (path_phase(path) + frame_) % refresh_ == 0;
    const ShapeNode* last = shape != kNoShape ? &shape_[shape] : nullptr;
    GoldenNodeRecord record;
    if (tracked) record.prediction = predictor_.predict(path, depth);
    if (std::getenv("DBG2") && tracked) {
      static std::atomic<long> c[4];
      ++c[record.prediction ? 0 : last ? 1 : 2];
      if (path == kRootPath && frame_ > 2) fprintf(stderr, "large: predicted %ld noprediction %ld noshape %ld\n", c[0].load(), c[1].load(), c[2].load());
    }
    const std::optional<SplitPrediction>& prediction = record.prediction;
    double axis_costs[3] = {kInfinity, kInfinity, kInfinity};
    bool all_axes = false;
    best.cost = kInfinity;
    if (prediction && cell.lo[prediction->axis] < cell.hi[prediction->axis]) {
      // Paper 000's Algorithm 1: the predicted bracket first.
      const int a = prediction->axis;
      const double lo = cell.lo[a], extent = static_cast<double>(cell.hi[a]) - lo;
      const double center = lo + prediction->fraction * extent;
      const double half = prediction->half_width * extent;
      const GoldenSearchResult r =
          search_bracket(prims, cell, a, cost_, static_cast<float>(center - half),
                         static_cast<float>(center + half), static_cast<float>(center), scratch);
      evals += r.evals;
      if (r.best.valid() && !r.at_bracket_edge &&
          r.best.cost <= prediction->max_cost_ratio * cost_.leaf(n)) {
        record.used_prediction = true;
        best.axis = a;
        best.position = r.best.position;
        best.cost = axis_costs[a] = r.best.cost;
        best.n_below = r.best.n_below;
        best.n_above = r.best.n_above;
        best.planar_below = r.best.planar_below;
        if (prediction->check_axes || refresh) {
          const BinnedSplit others =
              find_small_split(prims, cell, cost_, axis_costs, 7u & ~(1u << a));
          evals += others.evals;
          axis_costs[a] = best.cost;
          if (others.axis >= 0 && others.cost < best.cost) best = others;
          all_axes = true;
        }
      } else {
        record.fell_back = true;
      }
    }
    if (best.axis < 0 && !prediction && last && !refresh && n <= kHintMax) {
      // No filter: last frame's decision at this place, re-checked in a bracket around it.
      if (last->axis == ShapeNode::kShapeLeaf) {
        if (!(kMode & 1) && n <= last->value) return {};  // a leaf whose content has not grown
      } else if (const int a = last->axis;
                 cell.lo[a] < last->position && last->position < cell.hi[a]) {
        const float half = static_cast<float>(shape_half_width_ * (cell.hi[a] - cell.lo[a]));
        const BracketSweep b = sweep_bracket(prims, cell, a, cost_, last->position - half,
                                             last->position + half, scratch);
        evals += b.split.evals;
        if (!(kMode & 2) && b.split.axis >= 0 && !b.at_edge) {
          best = b.split;
        } else {
          // The minimum lies beyond the bracket: the whole axis.
          best = find_small_split(prims, cell, cost_, axis_costs, kMode & 4 ? 7u : 1u << a);
          evals += best.evals;
        }
      }
    }
    if (std::getenv("DBG")) {
      static std::atomic<long> c[8], w[8];
      const int k = record.used_prediction ? 0 : record.fell_back ? 1 : !last ? 2 : refresh ? 3 : last->axis < 0 ? 4 : best.axis >= 0 ? 5 : 6;
      ++c[k]; w[k] += n;
      if (path == kRootPath && frame_ > 2) {
        for (int i = 0; i < 7; ++i) fprintf(stderr, "%s %ld %ld | ", (const char*[]){"kal","kalfail","noshape","refresh","grownleaf","bracket","outside"}[i], c[i].load(), w[i].load());
        fprintf(stderr, "\n");
      }
    }
    if (best.axis < 0) {
      // Nothing to go by, or it failed: golden's answer, the exact minimum over all axes.
      best = find_small_split(prims, cell, cost_, axis_costs);
      evals += best.evals;
      all_axes = true;
    }
    if (best.axis < 0 || !(best.cost < cost_.leaf(n))) return {};
    if (tracked) {
      SplitObservation& o = record.observation;
      if (all_axes) {
        double second = kInfinity;
        for (int a = 0; a < 3; ++a)
          if (a != best.axis) second = std::min(second, axis_costs[a]);
        o.axis_margin = std::isfinite(second) ? (second - best.cost) / best.cost : 1e9;
      }
      const double extent = static_cast<double>(cell.hi[best.axis]) - cell.lo[best.axis];
      o.path = path;
      o.depth = depth;
      o.axis = best.axis;
      o.fraction = (best.position - static_cast<double>(cell.lo[best.axis])) / extent;
      o.cost_ratio = best.cost / cost_.leaf(n);
      if (prediction && prediction->axis == best.axis) o.predicted = prediction->fraction;
      records.push_back(record);
    }
    return best;
  }

  // The last tree's nodes where the children's cells lie: one step down from the node's own
  // by the children's centres (a leaf stands for everything below it). Matched by place, not
  // by path, so that a node whose split changed axis still finds the last frame's structure.
  std::pair<std::uint32_t, std::uint32_t> child_shapes(std::uint32_t shape, const Aabb& below,
                                                       const Aabb& above) const {
    if (shape == kNoShape) return {kNoShape, kNoShape};
    const ShapeNode& s = shape_[shape];
    if (s.axis == ShapeNode::kShapeLeaf) return {kNoShape, kNoShape};
    const auto step = [&](const Aabb& cell) {
      const float centre = 0.5f * (cell.lo[s.axis] + cell.hi[s.axis]);
      return centre < s.position ? shape + 1 : s.value;
    };
    return {step(below), step(above)};
  }

  static std::pair<Aabb, Aabb> child_cells(const Aabb& cell, int axis, float position) {
    Aabb below = cell, above = cell;
    below.hi[axis] = position;
    above.lo[axis] = position;
    return {below, above};
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
  const SplitPredictor& predictor_;
  std::span<const ShapeNode> shape_;
  std::uint64_t frame_, refresh_;
  double shape_half_width_;
  mutable tbb::enumerable_thread_specific<Arenas> arenas_;
  KdSplitCost cost_;
  int max_depth_;
  std::size_t max_leaf_;
};

}  // namespace

KdBuildResult build_kd_rebuild(std::span<const Triangle> triangles, const Aabb& cell,
                               const BuildConfig& config, const SplitPredictor& predictor,
                               std::vector<GoldenNodeRecord>& records) {
  std::vector<PrimRef> prims;
  prims.reserve(triangles.size());
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    const Aabb b = triangles[i].bounds();
    if (!is_finite(b.lo) || !is_finite(b.hi)) continue;  // never hit: leave it out
    const Aabb clipped = intersection(b, cell);
    if (clipped.empty()) continue;
    prims.push_back({clipped, static_cast<std::uint32_t>(i)});
  }
  const RebuildBuilder builder(triangles, config, prims.size(), predictor);
  const std::uint32_t root = predictor.shape().empty() ? kNoShape : 0;
  KdBuildResult result;
  RecordPart rec;
  std::unique_ptr<KdPartial> top =
      builder.build_task(prims, cell, 0, kRootPath, root, result.cost_evals, rec);
  result.tree = assemble_kd(*top, cell);
  records.clear();
  rec.flatten(records);
  return result;
}

std::vector<ShapeNode> kd_shape(const KdTree& tree) {
  std::vector<ShapeNode> shape(tree.nodes.size());
  for (std::size_t i = 0; i < tree.nodes.size(); ++i) {
    const KdNode& node = tree.nodes[i];
    if (node.is_leaf()) {
      shape[i].value = node.count();
    } else {
      shape[i].axis = node.axis();
      shape[i].value = node.above();
      shape[i].position = node.split;
    }
  }
  return shape;
}

}  // namespace splitray

// The `golden` kd builder (paper 000 §5, after Hussain & Grahn 2007): per node and axis
// the SAH minimum over the split position is searched by golden-section steps combined
// with parabolic interpolation (Brent), the primitive counts at each probe coming from
// binary searches in the node's sorted event lists (golden_search.hpp). The best axis wins;
// a node becomes a leaf by the rules shared with every kd builder (kd_sah.hpp).
//
// Where a search does not pay, the exact answer is cheaper: an axis with at most 128 events
// is swept event by event (golden_search.hpp), and a node of at most 32 primitives is
// finished by golden_small (bounds sorted on the spot, exact sweep), so the search runs on
// the upper levels, where nodes are large.
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
// tree is the same for any thread count.
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_invoke.h>

#include <limits>

#include "splitray/accel/kd/golden_events.hpp"
#include "splitray/accel/kd/golden_search.hpp"
#include "splitray/accel/kd/golden_small.hpp"
#include "splitray/accel/kd/kd_build.hpp"
#include "splitray/accel/kd/kd_sah.hpp"

namespace splitray {

namespace {

constexpr std::size_t kParallelSubtree = 2048;  // prims above which children build in parallel
constexpr std::size_t kParallelNode = 32768;    // prims above which one node's work is parallel
constexpr std::size_t kSmallPrims = 32;         // nodes this small finish in golden_small

struct Built {
  std::unique_ptr<KdBuildNode> node;
  std::uint64_t evals = 0;
};

class GoldenBuilder {
 public:
  GoldenBuilder(std::span<const Triangle> triangles, const BuildConfig& config, std::size_t prims)
      : triangles_(triangles),
        cost_(config),
        max_depth_(kd_max_depth(config, prims)),
        max_leaf_(static_cast<std::size_t>(std::max(config.max_leaf_prims, 0))) {}

  // A subtree: large ones keep their arrays on the heap and build their children as tasks,
  // small ones run sequentially on bump arenas.
  Built build_task(GoldenPrims& prims, const Aabb& cell, int depth) const {
    if (prims.size() >= kParallelSubtree) return build(prims, cell, depth, nullptr, nullptr);
    // Small subtrees never wait for other tasks, so one pair of arenas per thread serves all.
    Arenas& arenas = arenas_.local();
    const BumpArena::Mark mark = arenas.nodes.mark();
    Built built = build(prims, cell, depth, &arenas.nodes, &arenas.scratch);
    arenas.nodes.release(mark);
    return built;
  }

 private:
  Built build(GoldenPrims& prims, const Aabb& cell, int depth, BumpArena* nodes,
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

    // The best split of each axis, then the best axis (ties: the lower axis).
    GoldenSearchResult axes[3];
    const auto search = [&](int axis) {
      if (cell.lo[axis] < cell.hi[axis])
        axes[axis] = golden_search_axis(prims.axis_events(axis), cell, axis, cost_, cell.lo[axis],
                                        cell.hi[axis]);
    };
    const bool parallel = n >= kParallelNode;
    if (parallel)
      tbb::parallel_invoke([&] { search(0); }, [&] { search(1); }, [&] { search(2); });
    else
      for (int axis = 0; axis < 3; ++axis) search(axis);
    int axis = -1;
    for (int a = 0; a < 3; ++a) {
      out.evals += axes[a].evals;
      if (axes[a].best.valid() && (axis < 0 || axes[a].best.cost < axes[axis].best.cost)) axis = a;
    }
    if (axis < 0 || !(axes[axis].best.cost < cost_.leaf(n))) return make_leaf();

    const SplitCandidate& split = axes[axis].best;
    GoldenSplitOptions options;
    options.parallel = parallel;
    options.nodes = nodes;
    options.scratch = scratch;
    // Children at the depth limit or small enough become leaves: they need no event lists.
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
    Built b, a;
    if (!nodes) {
      tbb::parallel_invoke([&] { b = build_task(below, below_cell, depth + 1); },
                           [&] { a = build_task(above, above_cell, depth + 1); });
    } else {
      b = build(below, below_cell, depth + 1, nodes, scratch);
      a = build(above, above_cell, depth + 1, nodes, scratch);
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
  mutable tbb::enumerable_thread_specific<Arenas> arenas_;
  KdSplitCost cost_;
  int max_depth_;
  std::size_t max_leaf_;
};

}  // namespace

KdBuildResult build_kd_golden(std::span<const Triangle> triangles, const Aabb& cell,
                              const BuildConfig& config) {
  GoldenPrims prims = make_golden_prims(triangles, cell, triangles.size() >= kParallelNode);
  const GoldenBuilder builder(triangles, config, prims.size());
  Built built = builder.build_task(prims, cell, 0);
  KdBuildResult result;
  result.root = std::move(built.node);
  result.cost_evals = built.evals;
  return result;
}

}  // namespace splitray

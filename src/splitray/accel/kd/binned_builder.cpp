// The `binned` kd builder: binned SAH (binned_split.hpp) with config.bins bins per axis,
// perfect splits, and the termination rules shared by every kd builder (kd_sah.hpp).
// Large nodes bin and partition in parallel chunks and build their children as parallel
// tasks; small subtrees run sequentially on a per-thread bump arena. Decisions depend only
// on the data, so the tree is the same for any thread count.
//
// Measured (2 threads, SAH cost of the tree against `sah`'s): horse 1.06x, dragon 1.06x.
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_invoke.h>

#include <string>
#include <vector>

#include "splitray/accel/kd/binned_arena.hpp"
#include "splitray/accel/kd/binned_split.hpp"
#include "splitray/accel/kd/kd_build.hpp"
#include "splitray/accel/kd/kd_sah.hpp"
#include "splitray/core/errors.hpp"

namespace splitray {

namespace {

constexpr std::size_t kParallelSubtree = 2048;  // prims from which children build as tasks
constexpr std::size_t kParallelNode = 32768;    // prims from which a node bins in parallel
constexpr std::size_t kMinBins = 4;

struct Built {
  std::unique_ptr<KdBuildNode> node;
  std::uint64_t evals = 0;
};

class BinnedBuilder {
 public:
  BinnedBuilder(std::span<const Triangle> triangles, const BuildConfig& config, std::size_t prims)
      : triangles_(triangles),
        cost_(config),
        bins_(config.bins),
        max_depth_(kd_max_depth(config, prims)),
        max_leaf_(static_cast<std::size_t>(std::max(config.max_leaf_prims, 0))) {}

  // A node whose arrays are heap vectors; its children become tasks.
  Built build_large(std::vector<PrimRef> prims, const Aabb& cell, const Aabb& content,
                    int depth) const {
    Built out;
    const std::size_t n = prims.size();
    const bool parallel = n >= kParallelNode;
    const BinnedSplit split = choose(prims, cell, content, depth, parallel);
    out.evals = split.evals;
    if (split.axis < 0) {
      out.node = leaf(prims);
      return out;
    }
    std::vector<PrimRef> below(split.n_below), above(split.n_above);
    Aabb below_content, above_content;
    partition_binned(prims, triangles_, cell, split, below, above, below_content, above_content,
                     parallel);
    prims = {};
    const auto [below_cell, above_cell] = child_cells(cell, split);
    Built b, a;
    tbb::parallel_invoke(
        [&] { b = build_task(std::move(below), below_cell, below_content, depth + 1); },
        [&] { a = build_task(std::move(above), above_cell, above_content, depth + 1); });
    return join(std::move(out), split, std::move(b), std::move(a));
  }

 private:
  Built build_task(std::vector<PrimRef> prims, const Aabb& cell, const Aabb& content,
                   int depth) const {
    if (prims.size() >= kParallelSubtree)
      return build_large(std::move(prims), cell, content, depth);
    // Small subtrees never wait for other tasks, so one arena per thread serves them all.
    BumpArena& arena = arenas_.local();
    const BumpArena::Mark mark = arena.mark();
    Built built = build_small(prims, cell, content, depth, arena);
    arena.release(mark);
    return built;
  }

  // A node whose arrays live in `arena`: sequential below it.
  Built build_small(std::span<const PrimRef> prims, const Aabb& cell, const Aabb& content,
                    int depth, BumpArena& arena) const {
    Built out;
    const BinnedSplit split = choose(prims, cell, content, depth, false);
    out.evals = split.evals;
    if (split.axis < 0) {
      out.node = leaf(prims);
      return out;
    }
    const BumpArena::Mark mark = arena.mark();
    const std::span<PrimRef> below(arena.allocate<PrimRef>(split.n_below), split.n_below);
    const std::span<PrimRef> above(arena.allocate<PrimRef>(split.n_above), split.n_above);
    Aabb below_content, above_content;
    partition_binned(prims, triangles_, cell, split, below, above, below_content, above_content,
                     false);
    const auto [below_cell, above_cell] = child_cells(cell, split);
    Built b = build_small(below, below_cell, below_content, depth + 1, arena);
    Built a = build_small(above, above_cell, above_content, depth + 1, arena);
    arena.release(mark);
    return join(std::move(out), split, std::move(b), std::move(a));
  }

  // The split to make, or axis -1 for a leaf (the rules shared by every kd builder).
  BinnedSplit choose(std::span<const PrimRef> prims, const Aabb& cell, const Aabb& content,
                     int depth, bool parallel) const {
    const std::size_t n = prims.size();
    if (n <= max_leaf_ || depth >= max_depth_ || !(cell.half_area() > 0)) return {};
    // A node uses at most one bin per two primitives (at least kMinBins): more planes would
    // mostly see the same counts, and their cost evaluations would outnumber the primitives.
    const int bins =
        static_cast<int>(std::min<std::size_t>(bins_, std::max<std::size_t>(kMinBins, n / 2)));
    BinnedSplit split = find_binned_split(prims, cell, content, cost_, bins, parallel);
    if (split.axis >= 0 && !(split.cost < cost_.leaf(n))) split.axis = -1;
    return split;
  }

  static std::pair<Aabb, Aabb> child_cells(const Aabb& cell, const BinnedSplit& split) {
    Aabb below = cell, above = cell;
    below.hi[split.axis] = split.position;
    above.lo[split.axis] = split.position;
    return {below, above};
  }

  static std::unique_ptr<KdBuildNode> leaf(std::span<const PrimRef> prims) {
    auto node = std::make_unique<KdBuildNode>();
    node->prims.reserve(prims.size());
    for (const PrimRef& r : prims) node->prims.push_back(r.id);
    return node;
  }

  static Built join(Built out, const BinnedSplit& split, Built below, Built above) {
    out.node = std::make_unique<KdBuildNode>();
    out.node->axis = split.axis;
    out.node->split = split.position;
    out.node->below = std::move(below.node);
    out.node->above = std::move(above.node);
    out.evals += below.evals + above.evals;
    return out;
  }

  std::span<const Triangle> triangles_;
  mutable tbb::enumerable_thread_specific<BumpArena> arenas_;
  KdSplitCost cost_;
  int bins_;
  int max_depth_;
  std::size_t max_leaf_;
};

}  // namespace

KdBuildResult build_kd_binned(std::span<const Triangle> triangles, const Aabb& cell,
                              const BuildConfig& config) {
  if (config.bins < 2)
    throw Error("--bins",
                "the binned builder needs at least 2 bins, got " + std::to_string(config.bins));
  std::vector<PrimRef> prims;
  prims.reserve(triangles.size());
  Aabb content;
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    const Aabb b = triangles[i].bounds();
    if (!is_finite(b.lo) || !is_finite(b.hi)) continue;  // never hit: leave it out
    const Aabb clipped = intersection(b, cell);
    if (clipped.empty()) continue;
    prims.push_back({clipped, static_cast<std::uint32_t>(i)});
    content.extend(clipped);
  }
  const BinnedBuilder builder(triangles, config, prims.size());
  Built built = builder.build_large(std::move(prims), cell, content, 0);
  KdBuildResult result;
  result.root = std::move(built.node);
  result.cost_evals = built.evals;
  return result;
}

}  // namespace splitray

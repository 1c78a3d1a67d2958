// The `binned` kd builder: binned SAH (binned_split.hpp) with config.bins bins per axis,
// perfect splits, and the termination rules shared by every kd builder (kd_sah.hpp). Nodes
// of at most 64 triangles, most of a tree's nodes, take their exact SAH split instead, as
// golden's do (golden_small.hpp): bins that few triangles share mostly miss the best plane
// (SAH cost 1.05-1.16x of sah's with bins everywhere, 0.97-1.02x with the exact small splits,
// for builds 0.8-1.4x as long, geometric mean 1.13x, over the 15 benchmark meshes).
// Large nodes bin and partition in parallel chunks and build their children as parallel
// tasks; small subtrees run sequentially on a per-thread bump arena. Decisions depend only
// on the data, so the tree is the same for any thread count.
//

#include <string>
#include <vector>

#include "splitray/accel/kd/binned_arena.hpp"
#include "splitray/accel/kd/binned_split.hpp"
#include "splitray/accel/kd/golden_small.hpp"
#include "splitray/accel/kd/kd_build.hpp"
#include "splitray/accel/kd/kd_emit.hpp"
#include "splitray/accel/kd/kd_sah.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

constexpr std::size_t kParallelSubtree = 2048;  // prims from which children build as tasks
constexpr std::size_t kParallelNode = 32768;    // prims from which a node bins in parallel
constexpr std::size_t kMinBins = 4;

class BinnedBuilder {
 public:
  BinnedBuilder(std::span<const Triangle> triangles, const BuildConfig& config, std::size_t prims)
      : triangles_(triangles),
        cost_(config),
        bins_(config.bins),
        max_depth_(kd_max_depth(config, prims)),
        max_leaf_(static_cast<std::size_t>(std::max(config.max_leaf_prims, 0))) {}

  // A node whose arrays are heap vectors; its children become tasks.
  std::unique_ptr<KdPartial> build_large(std::vector<PrimRef> prims, const Aabb& cell,
                                         const Aabb& content, int depth,
                                         std::uint64_t& evals) const {
    auto part = std::make_unique<KdPartial>();
    const std::size_t n = prims.size();
    const bool parallel = n >= kParallelNode;
    const BinnedSplit split = choose(prims, cell, content, depth, parallel);
    evals += split.evals;
    if (split.axis < 0) {
      add_leaf(prims, part->chunk);
      return part;
    }
    std::vector<PrimRef> below(split.n_below), above(split.n_above);
    Aabb below_content, above_content;
    partition_binned(prims, triangles_, cell, split, below, above, below_content, above_content,
                     parallel);
    prims = {};
    const auto [below_cell, above_cell] = child_cells(cell, split);
    part->axis = split.axis;
    part->split = split.position;
    std::uint64_t eb = 0, ea = 0;
    // Structured bindings captured by copy: clang 14 (the fuzz build) cannot capture them by &.
    parallel_invoke(
        [&, below_cell = below_cell] {
          part->below = build_task(std::move(below), below_cell, below_content, depth + 1, eb);
        },
        [&, above_cell = above_cell] {
          part->above = build_task(std::move(above), above_cell, above_content, depth + 1, ea);
        });
    evals += eb + ea;
    return part;
  }

 private:
  std::unique_ptr<KdPartial> build_task(std::vector<PrimRef> prims, const Aabb& cell,
                                        const Aabb& content, int depth,
                                        std::uint64_t& evals) const {
    if (prims.size() >= kParallelSubtree)
      return build_large(std::move(prims), cell, content, depth, evals);
    // Small subtrees never wait for other tasks, so one arena per thread serves them all.
    auto part = std::make_unique<KdPartial>();
    BumpArena& arena = arenas_.local();
    const BumpArena::Mark mark = arena.mark();
    build_small(prims, cell, content, depth, arena, part->chunk, evals);
    arena.release(mark);
    return part;
  }

  // A node whose arrays live in `arena`: sequential below it, written into `out`.
  void build_small(std::span<const PrimRef> prims, const Aabb& cell, const Aabb& content, int depth,
                   BumpArena& arena, KdChunk& out, std::uint64_t& evals) const {
    const BinnedSplit split = choose(prims, cell, content, depth, false);
    evals += split.evals;
    if (split.axis < 0) {
      add_leaf(prims, out);
      return;
    }
    const BumpArena::Mark mark = arena.mark();
    const std::span<PrimRef> below(arena.allocate<PrimRef>(split.n_below), split.n_below);
    const std::span<PrimRef> above(arena.allocate<PrimRef>(split.n_above), split.n_above);
    Aabb below_content, above_content;
    partition_binned(prims, triangles_, cell, split, below, above, below_content, above_content,
                     false);
    const auto [below_cell, above_cell] = child_cells(cell, split);
    const std::size_t index = out.open_interior();
    build_small(below, below_cell, below_content, depth + 1, arena, out, evals);
    out.set_interior(index, split.axis, split.position);
    build_small(above, above_cell, above_content, depth + 1, arena, out, evals);
    arena.release(mark);
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
    BinnedSplit split = n <= kSmallSplitMaxPrims
                            ? find_small_split(prims, cell, cost_)
                            : find_binned_split(prims, cell, content, cost_, bins, parallel);
    if (split.axis >= 0 && !(split.cost < cost_.leaf(n))) split.axis = -1;
    return split;
  }

  static std::pair<Aabb, Aabb> child_cells(const Aabb& cell, const BinnedSplit& split) {
    Aabb below = cell, above = cell;
    below.hi[split.axis] = split.position;
    above.lo[split.axis] = split.position;
    return {below, above};
  }

  static void add_leaf(std::span<const PrimRef> prims, KdChunk& out) {
    out.nodes.push_back(KdNode::leaf(static_cast<std::uint32_t>(out.prims.size()),
                                     static_cast<std::uint32_t>(prims.size())));
    for (const PrimRef& r : prims) out.prims.push_back(r.id);
  }

  std::span<const Triangle> triangles_;
  mutable ThreadLocal<BumpArena> arenas_;
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
  KdBuildResult result;
  auto top = builder.build_large(std::move(prims), cell, content, 0, result.cost_evals);
  result.tree = assemble_kd(*top, cell);
  return result;
}

}  // namespace splitray

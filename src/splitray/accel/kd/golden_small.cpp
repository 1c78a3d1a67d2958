#include "splitray/accel/kd/golden_small.hpp"

#include <algorithm>
#include <array>
#include <limits>
#include <vector>

#include "splitray/accel/kd/golden_search.hpp"

namespace splitray {

BinnedSplit find_small_split(std::span<const PrimRef> prims, const Aabb& cell,
                             const KdSplitCost& cost) {
  const std::size_t n = prims.size();
  constexpr std::size_t kStack = 64;
  std::array<float, 3 * kStack> stack_lists;
  std::vector<float> heap_lists;
  float* starts = stack_lists.data();
  if (n > kStack) {
    heap_lists.resize(3 * n);
    starts = heap_lists.data();
  }
  float* ends = starts + n;
  float* planes = ends + n;
  BinnedSplit best;
  best.cost = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (!(cell.lo[a] < cell.hi[a])) continue;
    std::size_t n_spans = 0, n_planes = 0;
    for (const PrimRef& r : prims) {
      const float lo = r.bounds.lo[a], hi = r.bounds.hi[a];
      if (lo == hi) {
        planes[n_planes++] = lo;
      } else {
        starts[n_spans] = lo;
        ends[n_spans++] = hi;
      }
    }
    std::sort(starts, starts + n_spans);
    std::sort(ends, ends + n_spans);
    std::sort(planes, planes + n_planes);
    const AxisEvents events{{starts, n_spans}, {ends, n_spans}, {planes, n_planes}};
    const GoldenSearchResult r =
        exhaustive_search_axis(events, cell, a, cost, cell.lo[a], cell.hi[a]);
    best.evals += r.evals;
    if (r.best.valid() && r.best.cost < best.cost) {
      best.cost = r.best.cost;
      best.axis = a;
      best.position = r.best.position;
      best.n_below = r.best.n_below;
      best.n_above = r.best.n_above;
      best.planar_below = r.best.planar_below;
    }
  }
  return best;
}

std::unique_ptr<KdBuildNode> build_small_subtree(const SmallSubtree& build,
                                                 std::span<const PrimRef> prims, const Aabb& cell,
                                                 int depth, BumpArena& arena,
                                                 std::uint64_t& evals) {
  auto node = std::make_unique<KdBuildNode>();
  const std::size_t n = prims.size();
  BinnedSplit split;
  if (n > build.max_leaf && depth < build.max_depth && cell.half_area() > 0) {
    split = find_small_split(prims, cell, build.cost);
    evals += split.evals;
  }
  if (split.axis < 0 || !(split.cost < build.cost.leaf(n))) {
    node->prims.reserve(n);
    for (const PrimRef& r : prims) node->prims.push_back(r.id);
    return node;
  }
  const BumpArena::Mark mark = arena.mark();
  const std::span<PrimRef> below(arena.allocate<PrimRef>(split.n_below), split.n_below);
  const std::span<PrimRef> above(arena.allocate<PrimRef>(split.n_above), split.n_above);
  Aabb below_content, above_content;
  partition_binned(prims, build.triangles, cell, split, below, above, below_content, above_content,
                   false);
  Aabb below_cell = cell, above_cell = cell;
  below_cell.hi[split.axis] = split.position;
  above_cell.lo[split.axis] = split.position;
  node->axis = split.axis;
  node->split = split.position;
  node->below = build_small_subtree(build, below, below_cell, depth + 1, arena, evals);
  node->above = build_small_subtree(build, above, above_cell, depth + 1, arena, evals);
  arena.release(mark);
  return node;
}

}  // namespace splitray

#include "splitray/accel/kd/golden_small.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cstdint>
#include <limits>
#include <vector>

#include "splitray/accel/kd/golden_search.hpp"

namespace splitray {

namespace {

// A float as an unsigned key of the same order (-0 made +0 first, as the sweep compares).
std::uint32_t order_key(float f) {
  const std::uint32_t u = std::bit_cast<std::uint32_t>(f + 0.0f);
  return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}
float from_key(std::uint32_t k) {
  return std::bit_cast<float>((k & 0x80000000u) ? (k & 0x7fffffffu) : ~k);
}

// Event types in sweep order at one position, as in exhaustive_search_axis: primitives
// ending there leave the above side first, in-plane ones are placed, starting ones join
// the below side after the plane is costed.
enum : std::uint64_t { kEnd = 0, kPlane = 1, kStart = 2 };

}  // namespace

// One sorted array of (position, type) keys per axis and one linear sweep over it: the
// same positions, counts, costs and ties as exhaustive_search_axis over three sorted lists,
// with one sort and no three-way merge (small nodes are most of a kd build's nodes).
BinnedSplit find_small_split(std::span<const PrimRef> prims, const Aabb& cell,
                             const KdSplitCost& cost, double* axis_costs) {
  const std::size_t n = prims.size();
  constexpr std::size_t kStack = 64;
  std::array<std::uint64_t, 2 * kStack> stack_keys;
  std::vector<std::uint64_t> heap_keys;
  std::uint64_t* keys = stack_keys.data();
  if (n > kStack) {
    heap_keys.resize(2 * n);
    keys = heap_keys.data();
  }
  BinnedSplit best;
  best.cost = std::numeric_limits<double>::infinity();
  if (axis_costs)
    for (int a = 0; a < 3; ++a) axis_costs[a] = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    const float cell_lo = cell.lo[a], cell_hi = cell.hi[a];
    if (!(cell_lo < cell_hi)) continue;
    std::size_t m = 0;
    for (const PrimRef& r : prims) {
      const float lo = r.bounds.lo[a], hi = r.bounds.hi[a];
      if (lo == hi) {
        keys[m++] = (std::uint64_t{order_key(lo)} << 2) | kPlane;
      } else {
        keys[m++] = (std::uint64_t{order_key(lo)} << 2) | kStart;
        keys[m++] = (std::uint64_t{order_key(hi)} << 2) | kEnd;
      }
    }
    std::sort(keys, keys + m);
    const KdAxisCost axis_cost(cost, cell, a);
    double a_cost = std::numeric_limits<double>::infinity();
    float a_pos = 0;
    std::size_t a_below = 0, a_above = 0;
    bool a_planar_below = true;
    std::size_t below = 0, above = n;
    for (std::size_t i = 0; i < m;) {
      const std::uint64_t at = keys[i] >> 2;
      std::size_t counts[3] = {0, 0, 0};
      for (; i < m && (keys[i] >> 2) == at; ++i) ++counts[keys[i] & 3];
      const std::size_t planar = counts[kPlane];
      above -= counts[kEnd] + planar;
      const float p = from_key(static_cast<std::uint32_t>(at));
      if (p > cell_lo && p < cell_hi) {
        double c = axis_cost(p, below + planar, above);
        ++best.evals;
        if (c < a_cost)
          a_cost = c, a_pos = p, a_below = below + planar, a_above = above, a_planar_below = true;
        if (planar > 0) {
          c = axis_cost(p, below, above + planar);
          ++best.evals;
          if (c < a_cost)
            a_cost = c, a_pos = p, a_below = below, a_above = above + planar,
            a_planar_below = false;
        }
      }
      below += counts[kStart] + planar;
    }
    if (!(a_cost < std::numeric_limits<double>::infinity())) continue;
    if (axis_costs) axis_costs[a] = a_cost;
    if (a_cost < best.cost) {
      best.cost = a_cost;
      best.axis = a;
      best.position = a_pos;
      best.n_below = a_below;
      best.n_above = a_above;
      best.planar_below = a_planar_below;
    }
  }
  return best;
}

void build_small_subtree(const SmallSubtree& build, std::span<const PrimRef> prims,
                         const Aabb& cell, int depth, BumpArena& arena, std::uint64_t& evals,
                         KdChunk& out) {
  const std::size_t n = prims.size();
  BinnedSplit split;
  if (n > build.max_leaf && depth < build.max_depth && cell.half_area() > 0) {
    split = find_small_split(prims, cell, build.cost);
    evals += split.evals;
  }
  if (split.axis < 0 || !(split.cost < build.cost.leaf(n))) {
    out.nodes.push_back(KdNode::leaf(static_cast<std::uint32_t>(out.prims.size()),
                                     static_cast<std::uint32_t>(n)));
    for (const PrimRef& r : prims) out.prims.push_back(r.id);
    return;
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
  const std::size_t index = out.open_interior();
  build_small_subtree(build, below, below_cell, depth + 1, arena, evals, out);
  out.set_interior(index, split.axis, split.position);
  build_small_subtree(build, above, above_cell, depth + 1, arena, evals, out);
  arena.release(mark);
}

}  // namespace splitray

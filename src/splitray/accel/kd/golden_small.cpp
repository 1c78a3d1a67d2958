#include "splitray/accel/kd/golden_small.hpp"

#include <bit>
#include <cstdint>
#include <limits>
#include <stdexcept>

#include "splitray/accel/kd/golden_search.hpp"

#if defined(__AVX__)
#include <immintrin.h>
#endif

namespace splitray {

namespace {

// One axis of the node's bounds, a lane per primitive; the padding up to a whole vector
// never counts (lo = +inf is below no position, hi = -inf above none).
struct AxisLanes {
  alignas(64) float lo[kSmallSplitMaxPrims];
  alignas(64) float hi[kSmallSplitMaxPrims];
  std::size_t n = 0, padded = 0;
  std::uint64_t planar = 0;          // bit i: primitive i lies in a plane of this axis (lo == hi)
  std::size_t at_lo = 0, at_hi = 0;  // primitives lying in the cell's lower / upper face
};

// The primitives' positions relative to a plane at p, as bit masks over the lanes.
struct PlaneMasks {
  std::uint64_t lo_below = 0;  // lo < p
  std::uint64_t lo_at = 0;     // lo == p
  std::uint64_t hi_above = 0;  // hi > p
  std::uint64_t hi_at = 0;     // hi == p
};

#if defined(__AVX512F__)
constexpr std::size_t kLanes = 16;
PlaneMasks plane_masks(const AxisLanes& l, float p) {
  const __m512 v = _mm512_set1_ps(p);
  PlaneMasks m;
  for (std::size_t i = 0; i < l.padded; i += kLanes) {
    const __m512 lo = _mm512_load_ps(l.lo + i), hi = _mm512_load_ps(l.hi + i);
    m.lo_below |= std::uint64_t{_mm512_cmp_ps_mask(lo, v, _CMP_LT_OQ)} << i;
    m.lo_at |= std::uint64_t{_mm512_cmp_ps_mask(lo, v, _CMP_EQ_OQ)} << i;
    m.hi_above |= std::uint64_t{_mm512_cmp_ps_mask(hi, v, _CMP_GT_OQ)} << i;
    m.hi_at |= std::uint64_t{_mm512_cmp_ps_mask(hi, v, _CMP_EQ_OQ)} << i;
  }
  return m;
}
#elif defined(__AVX__)
constexpr std::size_t kLanes = 8;
PlaneMasks plane_masks(const AxisLanes& l, float p) {
  const __m256 v = _mm256_set1_ps(p);
  PlaneMasks m;
  const auto bits = [](__m256 c) {
    return static_cast<std::uint64_t>(static_cast<unsigned>(_mm256_movemask_ps(c)));
  };
  for (std::size_t i = 0; i < l.padded; i += kLanes) {
    const __m256 lo = _mm256_load_ps(l.lo + i), hi = _mm256_load_ps(l.hi + i);
    m.lo_below |= bits(_mm256_cmp_ps(lo, v, _CMP_LT_OQ)) << i;
    m.lo_at |= bits(_mm256_cmp_ps(lo, v, _CMP_EQ_OQ)) << i;
    m.hi_above |= bits(_mm256_cmp_ps(hi, v, _CMP_GT_OQ)) << i;
    m.hi_at |= bits(_mm256_cmp_ps(hi, v, _CMP_EQ_OQ)) << i;
  }
  return m;
}
#else
constexpr std::size_t kLanes = 1;
PlaneMasks plane_masks(const AxisLanes& l, float p) {
  PlaneMasks m;
  for (std::size_t i = 0; i < l.n; ++i) {
    const std::uint64_t bit = std::uint64_t{1} << i;
    if (l.lo[i] < p) m.lo_below |= bit;
    if (l.lo[i] == p) m.lo_at |= bit;
    if (l.hi[i] > p) m.hi_above |= bit;
    if (l.hi[i] == p) m.hi_at |= bit;
  }
  return m;
}
#endif

void load_axis(std::span<const PrimRef> prims, const Aabb& cell, int axis, AxisLanes& l) {
  l.n = prims.size();
  l.padded = (l.n + kLanes - 1) / kLanes * kLanes;
  l.planar = 0;
  l.at_lo = l.at_hi = 0;
  for (std::size_t i = 0; i < l.n; ++i) {
    l.lo[i] = prims[i].bounds.lo[axis];
    l.hi[i] = prims[i].bounds.hi[axis];
    const bool planar = l.lo[i] == l.hi[i];
    if (planar) l.planar |= std::uint64_t{1} << i;
    l.at_lo += planar && l.lo[i] == cell.lo[axis];
    l.at_hi += planar && l.lo[i] == cell.hi[axis];
  }
  for (std::size_t i = l.n; i < l.padded; ++i) {
    l.lo[i] = std::numeric_limits<float>::infinity();
    l.hi[i] = -std::numeric_limits<float>::infinity();
  }
}

// The distinct bounds strictly inside the cell on one axis, with their counts, and then
// their costs, a lane each.
struct Candidates {
  alignas(64) float position[2 * kSmallSplitMaxPrims];
  alignas(64) double extent_below[2 * kSmallSplitMaxPrims];  // of the cell below the plane
  alignas(64) double extent_above[2 * kSmallSplitMaxPrims];
  alignas(64) double below[2 * kSmallSplitMaxPrims];  // lo < p, in-plane ones at p left out
  alignas(64) double above[2 * kSmallSplitMaxPrims];  // hi > p, the same
  alignas(64) double planar[2 * kSmallSplitMaxPrims];
  alignas(64) double cost_planar_below[2 * kSmallSplitMaxPrims];
  alignas(64) double cost_planar_above[2 * kSmallSplitMaxPrims];  // inf without in-plane ones
  std::size_t m = 0;
};

// First the bounds strictly inside the cell (a lane's hi only where it is not in-plane), in a
// branch-free pass: which bounds those are is data the branch predictor cannot learn (on the
// dragon 39% of the small nodes' bounds are clipped to a face or lie outside, on sibenik 55%),
// and only they cost a count. A bound is then kept (the next one written after it) unless a
// lower lane has a bound at the same position, so each position is costed once.
void collect_candidates(const AxisLanes& lanes, const KdAxisCost& axis_cost, float cell_lo,
                        float cell_hi, Candidates& c) {
  float inside[2 * kSmallSplitMaxPrims];
  std::uint8_t lane[2 * kSmallSplitMaxPrims];
  std::size_t k = 0;
  for (std::size_t i = 0; i < lanes.n; ++i) {
    const float lo = lanes.lo[i], hi = lanes.hi[i];
    const bool planar = lanes.planar >> i & 1;
    inside[k] = lo;
    lane[k] = static_cast<std::uint8_t>(i);
    k += (lo > cell_lo) & (lo < cell_hi);
    inside[k] = hi;
    lane[k] = static_cast<std::uint8_t>(i);
    k += (hi > cell_lo) & (hi < cell_hi) & !planar;
  }
  std::size_t m = 0;
  for (std::size_t j = 0; j < k; ++j) {
    float p = inside[j];
    const PlaneMasks masks = plane_masks(lanes, p);
    const std::uint64_t earlier = (std::uint64_t{1} << lane[j]) - 1;
    const bool keep = !((masks.lo_at | masks.hi_at) & earlier);
    p += 0.0f;  // -0 as +0, as the sweep's order puts them together
    c.position[m] = p;
    c.extent_below[m] = axis_cost.extent_below(p);
    c.extent_above[m] = axis_cost.extent_above(p);
    c.below[m] = static_cast<double>(std::popcount(masks.lo_below));
    c.above[m] = static_cast<double>(std::popcount(masks.hi_above));
    c.planar[m] = static_cast<double>(std::popcount(masks.lo_at & lanes.planar));
    m += keep;
  }
  c.m = m;
}

// Both placements of the in-plane primitives costed for every candidate in one loop the
// compiler vectorises (the same KdAxisCost expression, so the same bits as the sweep's).
// Not inlined: inlined into its caller, GCC 12 no longer vectorises the loop.
[[gnu::noinline]] void cost_candidates(const KdAxisCost& axis_cost, Candidates& c) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const double* __restrict extent_below = c.extent_below;
  const double* __restrict extent_above = c.extent_above;
  const double* __restrict below = c.below;
  const double* __restrict above = c.above;
  const double* __restrict planar = c.planar;
  double* __restrict cost_planar_below = c.cost_planar_below;
  double* __restrict cost_planar_above = c.cost_planar_above;
  const KdAxisCost cost = axis_cost;  // a local copy: no store in the loop may alias it
  const std::size_t m = c.m;
  for (std::size_t k = 0; k < m; ++k) {
    const double lo = extent_below[k], hi = extent_above[k];
    cost_planar_below[k] = cost(lo, hi, below[k] + planar[k], above[k]);
    const double cost_above = cost(lo, hi, below[k], above[k] + planar[k]);
    cost_planar_above[k] = planar[k] > 0 ? cost_above : kInf;
  }
}

}  // namespace

// Every distinct bound strictly inside the cell is a candidate; its counts come from one
// vector compare per bound and lane block instead of a sort and sweep (small nodes are most
// of a kd build's nodes). Counting as exhaustive_search_axis does: below = lo < p, above =
// hi > p, in-plane primitives at p on either side; each position is costed once, and ties
// go to the lower position, then to the in-plane ones below, as in the ascending sweep.
BinnedSplit find_small_split(std::span<const PrimRef> prims, const Aabb& cell,
                             const KdSplitCost& cost, double* axis_costs) {
  if (prims.size() > kSmallSplitMaxPrims)
    throw std::logic_error("find_small_split: more primitives than one mask holds");
  constexpr double kInf = std::numeric_limits<double>::infinity();
  BinnedSplit best;
  best.cost = kInf;
  if (axis_costs)
    for (int a = 0; a < 3; ++a) axis_costs[a] = kInf;
  AxisLanes lanes;
  Candidates c;
  for (int a = 0; a < 3; ++a) {
    const float cell_lo = cell.lo[a], cell_hi = cell.hi[a];
    if (!(cell_lo < cell_hi)) continue;
    load_axis(prims, cell, a, lanes);
    const KdAxisCost axis_cost(cost, cell, a);
    collect_candidates(lanes, axis_cost, cell_lo, cell_hi, c);
    cost_candidates(axis_cost, c);
    double a_cost = kInf;
    float a_pos = 0;
    std::size_t a_below = 0, a_above = 0;
    bool a_planar_below = true;
    const auto consider = [&](double cost_k, float p, double below, double above,
                              bool planar_below) {
      if (cost_k < a_cost || (cost_k == a_cost && p < a_pos))
        a_cost = cost_k, a_pos = p, a_below = static_cast<std::size_t>(below),
        a_above = static_cast<std::size_t>(above), a_planar_below = planar_below;
    };
    // The planar rule at the faces (kd_sah.hpp): in-plane primitives on a face into a flat
    // cell of their own.
    const std::size_t n = prims.size();
    if (lanes.at_lo > 0) {
      consider(axis_cost(cell_lo, lanes.at_lo, n - lanes.at_lo), cell_lo,
               static_cast<double>(lanes.at_lo), static_cast<double>(n - lanes.at_lo), true);
      ++best.evals;
    }
    for (std::size_t k = 0; k < c.m; ++k) {
      const double planar = c.planar[k];
      consider(c.cost_planar_below[k], c.position[k], c.below[k] + planar, c.above[k], true);
      consider(c.cost_planar_above[k], c.position[k], c.below[k], c.above[k] + planar, false);
      best.evals += 1 + (planar > 0);
    }
    if (lanes.at_hi > 0) {
      consider(axis_cost(cell_hi, n - lanes.at_hi, lanes.at_hi), cell_hi,
               static_cast<double>(n - lanes.at_hi), static_cast<double>(lanes.at_hi), false);
      ++best.evals;
    }
    if (!(a_cost < kInf)) continue;
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

}  // namespace splitray

#include "splitray/accel/kd/binned_split.hpp"

#include <algorithm>
#include <array>
#include <limits>
#include <vector>

#include "splitray/accel/kd/golden_search.hpp"
#include "splitray/accel/triangle_clip.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

constexpr std::size_t kChunk = 8192;  // primitives per parallel chunk
constexpr int kStackBins = 256;       // histograms of up to this many bins live on the stack

struct AxisBins {
  float lo, scale;
  int bins;
  int operator()(float v) const {
    const int b = static_cast<int>((v - lo) * scale);
    return std::clamp(b, 0, bins - 1);
  }
};

// Histograms [axis][lo / hi][bins] of the bins of the primitives' lower and upper bounds,
// then [axis][lower / upper face] the primitives lying in each face of the cell, counted only
// where the content reaches that face (`faces`: bit 2a lower, 2a + 1 upper face of axis a).
void bin_prims(std::span<const PrimRef> prims, const Aabb& cell, const AxisBins* axes,
               const bool* active, unsigned faces, std::uint32_t* hist, std::size_t bins) {
  for (int a = 0; a < 3; ++a) {
    const std::size_t axis = static_cast<std::size_t>(a);
    std::uint32_t* h_lo = hist + 2 * axis * bins;
    std::uint32_t* h_hi = h_lo + bins;
    std::uint32_t* on_face = hist + 6 * bins + 2 * axis;
    const AxisBins bin = axes[a];
    const float face_lo = cell.lo[a], face_hi = cell.hi[a];
    const bool count_lo = faces >> (2 * a) & 1, count_hi = faces >> (2 * a + 1) & 1;
    if (count_lo || count_hi) {
      std::uint32_t at_lo = 0, at_hi = 0;
      for (const PrimRef& r : prims) {
        const float lo = r.bounds.lo[a], hi = r.bounds.hi[a];
        if (active[a]) ++h_lo[bin(lo)], ++h_hi[bin(hi)];
        at_lo += lo == hi && lo == face_lo;
        at_hi += lo == hi && lo == face_hi;
      }
      on_face[0] += count_lo ? at_lo : 0;
      on_face[1] += count_hi ? at_hi : 0;
    } else if (active[a]) {
      for (const PrimRef& r : prims) {
        ++h_lo[bin(r.bounds.lo[a])];
        ++h_hi[bin(r.bounds.hi[a])];
      }
    }
  }
}

void count_sides(std::span<const PrimRef> prims, const BinnedSplit& split, std::size_t& below,
                 std::size_t& above) {
  below = above = 0;
  for (const PrimRef& r : prims) {
    const Side s = side_of(r.bounds, split.axis, split.position, split.planar_below);
    below += (s & kBelow) != 0;
    above += (s & kAbove) != 0;
  }
}

// The interior planes k = 1..bins-1 of one axis: their counts from the histograms, then all
// costed in one loop the compiler vectorises (KdAxisCost's expression, so the same bits as
// costing them one by one). Returns the first cheapest k of the planes inside (lo, hi) and
// the cell (0 if none) and adds those planes to `evals`. Not inlined: inlined
// into its caller, GCC 12 no longer vectorises the loop.
[[gnu::noinline]] int sweep_bins(const std::uint32_t* h_lo, const std::uint32_t* h_hi, int bins,
                                 std::size_t n, float lo, float hi, float width, float cell_lo,
                                 float cell_hi, const KdAxisCost& axis_cost, double* scratch,
                                 double& best_cost, std::uint64_t& evals) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const auto count = static_cast<std::size_t>(bins);
  double* __restrict below = scratch;
  double* __restrict above = scratch + count;
  double* __restrict cost = scratch + 2 * count;
  std::size_t b = 0, a = n;
  for (std::size_t k = 1; k < count; ++k) {
    b += h_lo[k - 1];
    a -= h_hi[k - 1];
    below[k] = static_cast<double>(b);
    above[k] = static_cast<double>(a);
  }
  const KdAxisCost c = axis_cost;  // a local copy: no store in the loop may alias it
  for (std::size_t k = 1; k < count; ++k) {
    const float position = lo + static_cast<float>(k) * width;
    cost[k] = c(c.extent_below(position), c.extent_above(position), below[k], above[k]);
  }
  int best = 0;
  double m = kInf;
  for (std::size_t k = 1; k < count; ++k) {
    const float position = lo + static_cast<float>(k) * width;
    if (!(position > lo && position < hi && position > cell_lo && position < cell_hi)) continue;
    ++evals;
    if (cost[k] < m) m = cost[k], best = static_cast<int>(k);
  }
  best_cost = m;
  return best;
}

}  // namespace

BinnedSplit find_binned_split(std::span<const PrimRef> prims, const Aabb& cell, const Aabb& content,
                              const KdSplitCost& cost, int bins, bool parallel) {
  bins = std::max(bins, 1);
  const std::size_t stride = static_cast<std::size_t>(bins);
  const std::size_t slots = 6 * stride + 6;  // the bins, then the face counts
  std::array<std::uint32_t, 6 * kStackBins + 6> stack_hist;
  std::vector<std::uint32_t> heap_hist;
  std::uint32_t* hist = stack_hist.data();
  if (bins > kStackBins) {
    heap_hist.resize(slots);
    hist = heap_hist.data();
  }
  std::fill(hist, hist + slots, 0u);
  std::array<double, std::size_t{3} * kStackBins> stack_sweep;  // sweep_bins' scratch
  std::vector<double> heap_sweep;
  double* sweep = stack_sweep.data();
  if (bins > kStackBins) {
    heap_sweep.resize(3 * stride);
    sweep = heap_sweep.data();
  }

  AxisBins axes[3];
  bool active[3];
  unsigned faces = 0;  // faces the content reaches: only they can hold in-plane primitives
  for (int a = 0; a < 3; ++a) {
    const float lo = content.lo[a], hi = content.hi[a];
    active[a] = lo < hi && cell.lo[a] < cell.hi[a];
    axes[a] = {lo, active[a] ? static_cast<float>(bins) / (hi - lo) : 0.0f, bins};
    if (cell.lo[a] < cell.hi[a]) {
      faces |= (lo == cell.lo[a] ? 1u : 0u) << (2 * a);
      faces |= (hi == cell.hi[a] ? 1u : 0u) << (2 * a + 1);
    }
  }
  if (parallel && prims.size() > kChunk) {
    const std::size_t chunks = (prims.size() + kChunk - 1) / kChunk;
    std::vector<std::uint32_t> partial(chunks * slots, 0u);
    parallel_for_each_index(chunks, [&](std::size_t c) {
      const std::size_t begin = c * kChunk, end = std::min(prims.size(), begin + kChunk);
      bin_prims(prims.subspan(begin, end - begin), cell, axes, active, faces,
                partial.data() + c * slots, stride);
    });
    for (std::size_t c = 0; c < chunks; ++c)  // integer sums: the same in any order
      for (std::size_t i = 0; i < slots; ++i) hist[i] += partial[c * slots + i];
  } else {
    bin_prims(prims, cell, axes, active, faces, hist, stride);
  }

  // Sweep of the planes at the bin boundaries k = 0..bins. Inside, the counts are the
  // bins' (exact up to bounds within rounding of a boundary). The outer two are the
  // empty-space cuts at the content's bounds, exact with in-plane primitives put on the
  // content's side. A content flat on an axis offers its plane, once per side.
  BinnedSplit best;
  best.cost = std::numeric_limits<double>::infinity();
  const std::size_t n = prims.size();
  // Costs a plane; the faces are candidates only by the planar rule (kd_sah.hpp), every other
  // plane must lie strictly inside the cell.
  const auto consider_plane = [&](int axis, float position, std::size_t below, std::size_t above,
                                  bool planar_below, const KdAxisCost& axis_cost) {
    const double c = axis_cost(position, below, above);
    ++best.evals;
    if (c < best.cost) {
      best.cost = c;
      best.axis = axis;
      best.position = position;
      best.planar_below = planar_below;
    }
  };
  const auto consider = [&](int axis, float position, std::size_t below, std::size_t above,
                            bool planar_below, const KdAxisCost& axis_cost) {
    if (position > cell.lo[axis] && position < cell.hi[axis])
      consider_plane(axis, position, below, above, planar_below, axis_cost);
  };
  for (int a = 0; a < 3; ++a) {
    const float lo = content.lo[a], hi = content.hi[a];
    if (!(cell.lo[a] < cell.hi[a]) || !(lo <= hi)) continue;
    const KdAxisCost axis_cost(cost, cell, a);
    const std::uint32_t* on_face = hist + 6 * stride + 2 * static_cast<std::size_t>(a);
    const std::size_t at_lo = on_face[0], at_hi = on_face[1];
    if (at_lo > 0) consider_plane(a, cell.lo[a], at_lo, n - at_lo, true, axis_cost);
    consider(a, lo, 0, n, false, axis_cost);
    if (active[a]) {
      const std::uint32_t* h_lo = hist + 2 * static_cast<std::size_t>(a) * stride;
      const std::uint32_t* h_hi = h_lo + stride;
      const float width = (hi - lo) / static_cast<float>(bins);
      double k_cost = 0;
      const int k = sweep_bins(h_lo, h_hi, bins, n, lo, hi, width, cell.lo[a], cell.hi[a],
                               axis_cost, sweep, k_cost, best.evals);
      if (k > 0 && k_cost < best.cost) {  // the first cheapest, as one by one in order
        best.cost = k_cost;
        best.axis = a;
        best.position = lo + static_cast<float>(k) * width;
        best.planar_below = true;
      }
    }
    consider(a, hi, n, 0, true, axis_cost);
    if (at_hi > 0) consider_plane(a, cell.hi[a], n - at_hi, at_hi, false, axis_cost);
  }
  if (best.axis < 0) return best;

  // The chosen plane's exact counts (the children's sizes) and exact cost.
  if (parallel && n > kChunk) {
    const std::size_t chunks = (n + kChunk - 1) / kChunk;
    std::vector<std::size_t> counts(2 * chunks);
    parallel_for_each_index(chunks, [&](std::size_t c) {
      const std::size_t begin = c * kChunk, end = std::min(n, begin + kChunk);
      count_sides(prims.subspan(begin, end - begin), best, counts[2 * c], counts[2 * c + 1]);
    });
    for (std::size_t c = 0; c < chunks; ++c)
      best.n_below += counts[2 * c], best.n_above += counts[2 * c + 1];
  } else {
    count_sides(prims, best, best.n_below, best.n_above);
  }
  best.cost = KdAxisCost(cost, cell, best.axis)(best.position, best.n_below, best.n_above);
  ++best.evals;
  return best;
}

void partition_binned(std::span<const PrimRef> prims, std::span<const Triangle> triangles,
                      const Aabb& cell, const BinnedSplit& split, std::span<PrimRef> below,
                      std::span<PrimRef> above, Aabb& below_content, Aabb& above_content,
                      bool parallel) {
  const int axis = split.axis;
  const float position = split.position;
  const bool planar_below = split.planar_below;
  Aabb below_cell = cell, above_cell = cell;
  below_cell.hi[axis] = position;
  above_cell.lo[axis] = position;
  // Writes chunk [begin, end) from output offsets (ob, oa); returns the contents.
  const auto write = [&](std::size_t begin, std::size_t end, std::size_t ob, std::size_t oa,
                         Aabb& cb, Aabb& ca) {
    for (std::size_t i = begin; i < end; ++i) {
      const PrimRef& r = prims[i];
      switch (side_of(r.bounds, axis, position, planar_below)) {
        case kBelow:
          below[ob++] = r;
          cb.extend(r.bounds);
          break;
        case kAbove:
          above[oa++] = r;
          ca.extend(r.bounds);
          break;
        case kBoth: {
          const Triangle& t = triangles[r.id];
          PrimRef& b = below[ob++];
          PrimRef& a = above[oa++];
          b.id = a.id = r.id;
          clip_triangle_split(t, cell, r.bounds, axis, position, b.bounds, a.bounds,
                              ClipTightness::slab);
          cb.extend(b.bounds);
          ca.extend(a.bounds);
          break;
        }
      }
    }
  };
  below_content = above_content = Aabb{};
  if (!parallel || prims.size() <= kChunk) {
    write(0, prims.size(), 0, 0, below_content, above_content);
    return;
  }
  const std::size_t chunks = (prims.size() + kChunk - 1) / kChunk;
  std::vector<std::size_t> offsets(2 * (chunks + 1), 0);
  parallel_for_each_index(chunks, [&](std::size_t c) {
    const std::size_t begin = c * kChunk, end = std::min(prims.size(), begin + kChunk);
    count_sides(prims.subspan(begin, end - begin), split, offsets[2 * (c + 1)],
                offsets[2 * (c + 1) + 1]);
  });
  for (std::size_t c = 0; c < chunks; ++c) {
    offsets[2 * (c + 1)] += offsets[2 * c];
    offsets[2 * (c + 1) + 1] += offsets[2 * c + 1];
  }
  std::vector<Aabb> contents(2 * chunks);
  parallel_for_each_index(chunks, [&](std::size_t c) {
    const std::size_t begin = c * kChunk, end = std::min(prims.size(), begin + kChunk);
    write(begin, end, offsets[2 * c], offsets[2 * c + 1], contents[2 * c], contents[2 * c + 1]);
  });
  for (std::size_t c = 0; c < chunks; ++c) {  // min / max: the same in any order
    below_content.extend(contents[2 * c]);
    above_content.extend(contents[2 * c + 1]);
  }
}

}  // namespace splitray

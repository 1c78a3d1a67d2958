#pragma once
// Binned SAH object splits over reference centres (Wald 2007, "On fast construction of
// SAH-based bounding volume hierarchies"), shared by the binned builder and SBVH: one pass
// bins every reference on all three axes at once (SIMD rows), one sweep rates the bin
// boundaries of the three axes at once, and partitioning reuses the binning's mapping.
#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "splitray/accel/bvh/bvh_build.hpp"

namespace splitray {

// Bounds of a set of references and of their centres.
struct RefBounds {
  Aabb box, centers;
  void extend(const BvhRef& r) {
    box.extend(r.box);
    centers.extend(r.center());
  }
  void extend(const RefBounds& o) {
    box.extend(o.box);
    centers.extend(o.centers);
  }
};

RefBounds ref_bounds(std::span<const BvhRef> refs);  // parallel for large spans

// RefBounds accumulated with SIMD rows (same result as RefBounds::extend: min/max are exact
// and (lo + hi) * 0.5 is taken after the min/max of lo + hi, which halving commutes with).
class RefBoundsAccumulator {
 public:
#if defined(__SSE2__)
  void add(const BvhRef& r) {
    const __m128 lo = _mm_loadu_ps(&r.box.lo.x);  // lane 3 (hi.x) is ignored
    const __m128 hi = _mm_loadu_ps(&r.box.hi.x);  // lane 3 (the id) is ignored
    const __m128 c2 = _mm_add_ps(lo, hi);
    lo_ = _mm_min_ps(lo_, lo);
    hi_ = _mm_max_ps(hi_, hi);
    c_lo_ = _mm_min_ps(c_lo_, c2);
    c_hi_ = _mm_max_ps(c_hi_, c2);
  }
  void add(const RefBoundsAccumulator& o) {
    lo_ = _mm_min_ps(lo_, o.lo_);
    hi_ = _mm_max_ps(hi_, o.hi_);
    c_lo_ = _mm_min_ps(c_lo_, o.c_lo_);
    c_hi_ = _mm_max_ps(c_hi_, o.c_hi_);
  }
  RefBounds bounds() const {
    alignas(16) float v[4][4];
    _mm_store_ps(v[0], lo_);
    _mm_store_ps(v[1], hi_);
    _mm_store_ps(v[2], c_lo_);
    _mm_store_ps(v[3], c_hi_);
    RefBounds b;
    b.box = {{v[0][0], v[0][1], v[0][2]}, {v[1][0], v[1][1], v[1][2]}};
    b.centers = {Vec3{v[2][0], v[2][1], v[2][2]} * 0.5f, Vec3{v[3][0], v[3][1], v[3][2]} * 0.5f};
    return b;
  }

 private:
  __m128 lo_ = _mm_set1_ps(std::numeric_limits<float>::infinity()),
         hi_ = _mm_set1_ps(-std::numeric_limits<float>::infinity());
  __m128 c_lo_ = lo_, c_hi_ = hi_;
#else
  void add(const BvhRef& r) { b_.extend(r); }
  void add(const RefBoundsAccumulator& o) { b_.extend(o.b_); }
  RefBounds bounds() const { return b_; }

 private:
  RefBounds b_;
#endif
};

inline constexpr int kMaxObjectBins = 256;

// Which bin of `axis` a centre falls in: the mapping both binning and partitioning use (the
// binning computes it for the three axes at once with the same float operations).
struct CenterBins {
  Vec3 lo, scale;
  int count;
  CenterBins(const Aabb& centers, int bins);
  int bin(const BvhRef& r, int axis) const {
    const float c = (r.box.lo[axis] + r.box.hi[axis]) * 0.5f;
    const int b = static_cast<int>((c - lo[axis]) * scale[axis]);
    return std::clamp(b, 0, count - 1);
  }
};

struct ObjectSplit {
  int axis = -1;     // -1: no split (all centres coincide)
  int bin = 0;       // references whose centre bin <= bin go left
  float cost = 0;    // K_T + K_I * (A_L N_L + A_R N_R) / A
  Aabb left, right;  // bounds of the two sides
  std::size_t n_left = 0;
};

// Bins for n references: 4 + n / 32 up to options.bins (Embree: 4 + n / 20). Small nodes are
// most of the nodes, and there the sweep over bins cost more than the binning itself; with
// 2n + 4 bins (before issue 26) the trees also came out 1-10% worse by the SAH cost of
// stats() on the 15 benchmark meshes (the greedy top-down choice is not the tree's optimum).
inline int bin_count(const BvhBuildOptions& options, std::size_t n) {
  return static_cast<int>(
      std::min<std::size_t>(static_cast<std::size_t>(options.bins), 4 + n / 32));
}

// Bounds and counts of the references whose centres fall in each bin, on all three axes.
// Only the bins in use are initialised; min/max and counts merge exactly, so a binning split
// over chunks gives the same result in any order.
class ObjectBins {
 public:
  explicit ObjectBins(int count);
  ObjectBins(const ObjectBins& o) : ObjectBins(o.count_) { merge(o); }
  ObjectBins& operator=(const ObjectBins&) = delete;

  void add(std::span<const BvhRef> refs, const CenterBins& map);
  void merge(const ObjectBins& o);
  // The cheapest boundary of `n` binned references whose bounds are `box`.
  ObjectSplit best(const CenterBins& map, std::size_t n, const Aabb& box,
                   const BvhBuildOptions& options, std::uint64_t& evals) const;

 private:
  struct alignas(16) Box {
    float lo[4], hi[4];  // lane 3 unused
  };
  int count_;
  Box box_[kMaxObjectBins][3];                           // [bin][axis]
  alignas(16) std::uint32_t counts_[kMaxObjectBins][4];  // [bin][axis], lane 3 unused
};

// The cheapest binned split of `refs` (bounds `bounds`); `evals` counts cost evaluations.
ObjectSplit find_object_split(std::span<const BvhRef> refs, const RefBounds& bounds,
                              const BvhBuildOptions& options, std::uint64_t& evals);

// Moves the references whose centre bin on split.axis is <= split.bin to the front and
// (bins = CenterBins(bounds.centers, bin_count(options, refs.size())), as in the search)
// returns their number, with the bounds of both sides.
std::size_t partition_refs(std::span<BvhRef> refs, const CenterBins& bins, const ObjectSplit& split,
                           RefBounds& left, RefBounds& right);

// The same split of a large span, in place and in parallel over fixed chunks (each chunk
// partitioned, then the misplaced references swapped in order): the order depends only on
// the data, never on the thread count.
std::size_t partition_refs_parallel(std::span<BvhRef> refs, const CenterBins& bins,
                                    const ObjectSplit& split, RefBounds& left, RefBounds& right);

// Large spans are binned and partitioned in parallel.
inline constexpr std::size_t kParallelSplitRefs = 32768;

// log2 of the block a leaf is costed by (leaf_block rounded down to a power of two, so that
// the sweep counts blocks with a shift).
inline int leaf_block_shift(const BvhBuildOptions& o) {
  return std::bit_width(static_cast<unsigned>(std::max(o.leaf_block, 1))) - 1;
}

// Intersection tests of a leaf with n references: one per block of leaf_block.
inline float leaf_tests(const BvhBuildOptions& o, std::size_t n) {
  const int shift = leaf_block_shift(o);
  return static_cast<float>((n + (std::size_t{1} << shift) - 1) >> shift);
}

// SAH cost of a leaf, and of a split with the given child measures (o.measure: areas, or
// areas and volumes) and counts, relative to the parent's measure.
inline float bvh_leaf_cost(const BvhBuildOptions& o, std::size_t n) {
  return o.intersection_cost * leaf_tests(o, n);
}
inline float bvh_split_cost(const BvhBuildOptions& o, float parent_measure, float left_measure,
                            std::size_t n_left, float right_measure, std::size_t n_right) {
  return o.traversal_cost +
         o.intersection_cost *
             (left_measure * leaf_tests(o, n_left) + right_measure * leaf_tests(o, n_right)) /
             parent_measure;
}

}  // namespace splitray

#pragma once
// The SAH of a kd split and the termination rule, shared by every kd builder
// (Wald & Havran 2006, §3): C(p) = lambda(p) * (K_T + K_I * (P_L N_L + P_R N_R)),
// lambda = 1 - empty_bonus when one side is empty; a node becomes a leaf when no split
// costs less than K_I * N, when N <= max_leaf_prims, or at the maximum depth.
//
// Candidate planes lie strictly inside the cell, with one exception every builder makes, the
// planar rule at the faces: a face holding primitives that lie in it is a candidate too, and
// cuts them off into a flat cell of their own (the rest keep the whole cell), as for a floor
// or a wall at the side of a room. Both children are smaller than the parent (one is flat,
// the other has fewer primitives), so such splits always progress.
#include <algorithm>
#include <cmath>
#include <cstddef>

#include "splitray/accel/accel.hpp"
#include "splitray/core/aabb.hpp"

namespace splitray {

// The kd-tree's K_T and K_I: the config's, else kd's measured defaults (accel.hpp). Every kd
// builder and the tree's statistics read them here, whichever way the tree is built.
inline SahConstants kd_sah(const BuildConfig& c) { return c.sah(kKdSah); }

struct KdSplitCost {
  double traversal, intersection, empty_factor;

  explicit KdSplitCost(const BuildConfig& c)
      : traversal(kd_sah(c).traversal),
        intersection(kd_sah(c).intersection),
        empty_factor(1.0 - c.empty_bonus) {}

  double leaf(std::size_t prims) const { return intersection * static_cast<double>(prims); }

  // Cost of cutting `box` at `position` on `axis` with n_below / n_above primitives.
  double split(const Aabb& box, int axis, float position, std::size_t n_below,
               std::size_t n_above) const;
};

// The one SAH expression of a kd split, for one cell and axis with the per-cell terms
// computed once (every kd builder, the golden search and the sweeps call it).
class KdAxisCost {
 public:
  KdAxisCost(const KdSplitCost& cost, const Aabb& box, int axis) : cost_(cost) {
    const Vec3 e = box.extent();
    const int a1 = axis == 2 ? 0 : axis + 1, a2 = a1 == 2 ? 0 : a1 + 1;
    inv_area_ = 1.0 / box.half_area();
    cap_ = static_cast<double>(e[a1]) * e[a2];   // the face cut by the plane
    ring_ = static_cast<double>(e[a1]) + e[a2];  // perimeter of that face / 2
    lo_ = box.lo[axis];
    hi_ = box.hi[axis];
  }

  double operator()(float position, std::size_t n_below, std::size_t n_above) const {
    return (*this)(position, static_cast<double>(n_below), static_cast<double>(n_above));
  }
  double operator()(float position, double n_below, double n_above) const {
    return (*this)(extent_below(position), extent_above(position), n_below, n_above);
  }
  // The same from the two cells' extents along the axis and the counts as doubles (exact
  // for any count): the form a loop over many positions vectorises.
  double extent_below(float position) const { return position - lo_; }
  double extent_above(float position) const { return hi_ - position; }
  double operator()(double below, double above, double n_below, double n_above) const {
    const double p_below = (cap_ + below * ring_) * inv_area_;
    const double p_above = (cap_ + above * ring_) * inv_area_;
    const double lambda = (n_below == 0 || n_above == 0) ? cost_.empty_factor : 1.0;
    return lambda *
           (cost_.traversal + cost_.intersection * (p_below * n_below + p_above * n_above));
  }

 private:
  const KdSplitCost& cost_;
  double inv_area_, cap_, ring_;
  float lo_, hi_;
};

inline double KdSplitCost::split(const Aabb& box, int axis, float position, std::size_t n_below,
                                 std::size_t n_above) const {
  return KdAxisCost(*this, box, axis)(position, n_below, n_above);
}

// Deepest tree the traversal's fixed stack takes; kd_max_depth never exceeds it.
inline constexpr int kKdDepthLimit = 64;

// 8 + 1.3 log2(N) levels, as in pbrt and Wald & Havran, unless the config says otherwise.
inline int kd_max_depth(const BuildConfig& config, std::size_t prims) {
  if (config.max_depth > 0) return std::min(config.max_depth, kKdDepthLimit);
  const double auto_depth =
      8 + 1.3 * std::log2(static_cast<double>(std::max<std::size_t>(prims, 1)));
  return std::min(static_cast<int>(std::lround(auto_depth)), kKdDepthLimit);
}

}  // namespace splitray

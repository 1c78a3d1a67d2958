#pragma once
// The SAH of a kd split and the termination rule, shared by every kd builder
// (Wald & Havran 2006, §3): C(p) = lambda(p) * (K_T + K_I * (P_L N_L + P_R N_R)),
// lambda = 1 - empty_bonus when one side is empty; a node becomes a leaf when no split
// costs less than K_I * N, when N <= max_leaf_prims, or at the maximum depth.
#include <cmath>
#include <cstddef>

#include "splitray/accel/accel.hpp"
#include "splitray/core/aabb.hpp"

namespace splitray {

struct KdSplitCost {
  double traversal, intersection, empty_factor;

  explicit KdSplitCost(const BuildConfig& c)
      : traversal(c.traversal_cost), intersection(c.intersection_cost), empty_factor(1.0 - c.empty_bonus) {}

  double leaf(std::size_t prims) const { return intersection * static_cast<double>(prims); }

  // Cost of cutting `box` at `position` on `axis` with n_below / n_above primitives.
  double split(const Aabb& box, int axis, float position, std::size_t n_below, std::size_t n_above) const {
    const Vec3 e = box.extent();
    const int a1 = axis == 2 ? 0 : axis + 1, a2 = a1 == 2 ? 0 : a1 + 1;
    const double inv_area = 1.0 / box.half_area();
    const double cap = static_cast<double>(e[a1]) * e[a2];      // the face cut by the plane
    const double ring = static_cast<double>(e[a1]) + e[a2];     // perimeter of that face / 2
    const double below = position - box.lo[axis], above = box.hi[axis] - position;
    const double p_below = (cap + below * ring) * inv_area;
    const double p_above = (cap + above * ring) * inv_area;
    const double lambda = (n_below == 0 || n_above == 0) ? empty_factor : 1.0;
    return lambda * (traversal + intersection * (p_below * static_cast<double>(n_below) +
                                                 p_above * static_cast<double>(n_above)));
  }
};

// 8 + 1.3 log2(N) levels, as in pbrt and Wald & Havran, unless the config says otherwise.
inline int kd_max_depth(const BuildConfig& config, std::size_t prims) {
  if (config.max_depth > 0) return config.max_depth;
  return static_cast<int>(std::lround(8 + 1.3 * std::log2(static_cast<double>(std::max<std::size_t>(prims, 1)))));
}

}  // namespace splitray

#pragma once
// The last levels of a golden build: a node of a few primitives is cheaper to finish by
// costing every one of its bounds (the exact SAH) than by keeping sorted event lists for a
// search that would need as many evaluations as there are events.
#include <cstddef>
#include <cstdint>
#include <span>

#include "splitray/accel/kd/binned_split.hpp"
#include "splitray/accel/kd/kd_sah.hpp"

namespace splitray {

// Most primitives find_small_split takes (its counts are bit masks of one 64-bit word).
inline constexpr std::size_t kSmallSplitMaxPrims = 64;

// The exact SAH minimum over the bounds of at most kSmallSplitMaxPrims primitives, and the
// faces holding in-plane ones (kd_sah.hpp; ties: lower axis, position), in-plane primitives
// on their cheaper side: the same positions,
// counts, costs and ties as exhaustive_search_axis. `axis_costs`, when given, receives each
// axis' best cost (infinity where none).
BinnedSplit find_small_split(std::span<const PrimRef> prims, const Aabb& cell,
                             const KdSplitCost& cost, double* axis_costs = nullptr);

}  // namespace splitray

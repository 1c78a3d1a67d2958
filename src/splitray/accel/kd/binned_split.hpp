#pragma once
// Binned SAH for kd nodes: min-max binning of the primitives' clipped bounds into `bins`
// slabs per axis over the node's content (its primitives' bounds within the cell, so the
// content's own bounds, the empty-space cuts, are candidates too, and the faces holding
// in-plane primitives, kd_sah.hpp), then one sweep over the bin boundaries. The chosen
// plane's counts are then taken exactly and its SAH evaluated again, so the leaf-or-split
// decision and the children's sizes are exact.
#include <cstddef>
#include <cstdint>
#include <span>

#include "splitray/accel/kd/kd_sah.hpp"
#include "splitray/core/triangle.hpp"

namespace splitray {

struct PrimRef {
  Aabb bounds;  // clipped to the node's cell
  std::uint32_t id;
};

struct BinnedSplit {
  int axis = -1;  // -1: no plane strictly inside the cell
  float position = 0;
  double cost = 0;
  std::size_t n_below = 0, n_above = 0;  // straddlers count on both sides
  bool planar_below = true;              // where primitives lying in the plane go
  std::uint64_t evals = 0;               // SAH cost evaluations made
};

// Which child of a split at `position` on `axis` a primitive with (clipped) bounds `b` goes to:
// straddlers to both, primitives lying in the plane below if `planar_below`.
enum Side : std::uint8_t { kBelow = 1, kAbove = 2, kBoth = 3 };
inline Side side_of(const Aabb& b, int axis, float position, bool planar_below) {
  const float lo = b.lo[axis], hi = b.hi[axis];
  if (lo == position && hi == position) return planar_below ? kBelow : kAbove;
  if (lo < position) return hi > position ? kBoth : kBelow;
  return kAbove;
}

// The cheapest bin boundary over all axes (ties: lower axis, then lower position), with its
// exact counts and cost. `parallel` bins and counts large nodes in parallel chunks.
BinnedSplit find_binned_split(std::span<const PrimRef> prims, const Aabb& cell, const Aabb& content,
                              const KdSplitCost& cost, int bins, bool parallel);

// Writes the primitives of the two children (sizes n_below / n_above of the split) in the parent's
// order: straddlers go to both with bounds re-clipped to each child cell (perfect splits),
// primitives in the plane go below if split.planar_below. Returns the children's contents.
void partition_binned(std::span<const PrimRef> prims, std::span<const Triangle> triangles,
                      const Aabb& cell, const BinnedSplit& split, std::span<PrimRef> below,
                      std::span<PrimRef> above, Aabb& below_content, Aabb& above_content,
                      bool parallel);

}  // namespace splitray

#pragma once
// The last levels of a golden build: a node of a few primitives is cheaper to finish by
// sorting its primitives' bounds on the spot and costing every one (the exact SAH) than by
// keeping sorted event lists for a search that would need as many evaluations as there are
// events. Its arrays live on a bump arena.
#include <cstdint>
#include <memory>
#include <span>

#include "splitray/accel/kd/binned_arena.hpp"
#include "splitray/accel/kd/binned_split.hpp"
#include "splitray/accel/kd/kd_build.hpp"
#include "splitray/accel/kd/kd_emit.hpp"
#include "splitray/accel/kd/kd_sah.hpp"

namespace splitray {

struct SmallSubtree {
  std::span<const Triangle> triangles;
  const KdSplitCost& cost;
  int max_depth;
  std::size_t max_leaf;
};

// Builds the subtree of `prims` (bounds clipped to `cell`) at `depth` by the shared rules
// into `out`; adds its cost evaluations to `evals`.
void build_small_subtree(const SmallSubtree& build, std::span<const PrimRef> prims,
                         const Aabb& cell, int depth, BumpArena& arena, std::uint64_t& evals,
                         KdChunk& out);

// The exact SAH minimum over the bounds of a few primitives (ties: lower axis, position),
// in-plane primitives on their cheaper side. `axis_costs`, when given, receives each axis'
// best cost (infinity where none).
BinnedSplit find_small_split(std::span<const PrimRef> prims, const Aabb& cell,
                             const KdSplitCost& cost, double* axis_costs = nullptr);

}  // namespace splitray

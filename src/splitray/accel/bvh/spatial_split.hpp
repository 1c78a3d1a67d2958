#pragma once
// The SBVH's spatial split search (Stich, Friedrich & Dietrich 2009, §4.3): the node's box cut
// into equal slabs on each axis, every reference's triangle part in each slab it crosses
// binned with its bounds, and the slab boundaries rated by the SAH with the counts of
// references entering and leaving. The parts' bounds are estimates in float (they only rate
// candidates); the references a chosen split makes are clipped conservatively by
// split_triangle_bounds (triangle_clip.hpp).
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>

#include "splitray/accel/bvh/bvh_build.hpp"

namespace splitray {

struct SpatialSplit {
  int axis = -1;
  float plane = 0;
  float cost = std::numeric_limits<float>::infinity();
  Aabb left, right;
  std::size_t n_left = 0, n_right = 0;
};

// The cheapest spatial split of `refs` (the references of a node with bounds `box`; each
// refers to a triangle of `triangles`); `evals` counts cost evaluations. Large spans are
// binned in parallel (min, max and counts merge exactly: the same split for any thread count).
SpatialSplit find_spatial_split(std::span<const BvhRef> refs, std::span<const Triangle> triangles,
                                const Aabb& box, const BvhBuildOptions& options,
                                std::uint64_t& evals);

}  // namespace splitray

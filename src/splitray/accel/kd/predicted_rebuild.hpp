#pragma once
// The kd build of frame k+1 of an animation from what frames 1..k left behind (paper 000
// §5, Algorithm 1, carried down to the small nodes): a node the filters track (more than 32
// primitives) searches its predicted bracket on the predicted axis in one pass over its
// primitives' bounds; every other node sweeps exactly, but only on the axis its path split
// in the last frame's tree, and a path that was a leaf stays one while its content has not
// grown. Every node re-checks all three axes when its prediction fails, when its path is
// new or changed axis, and once every `refresh_frames` frames (staggered over the paths),
// so a decision reused from the last frame is never older than that.
//
// No node keeps sorted event lists (nothing to split or merge): the one-axis sweeps sort
// their node's bounds on the spot. Every decision depends only on the data, the filters and
// the last frame's shape, so the tree is the same for any thread count.
#include <span>
#include <vector>

#include "splitray/accel/kd/golden_build.hpp"
#include "splitray/accel/kd/kd_build.hpp"
#include "splitray/accel/predict/split_predictor.hpp"

namespace splitray {

// Builds the tree of `triangles` in `cell` steered by `predictor` (its filters and
// shape()); the tracked nodes' records go to `records`, in depth-first order.
KdBuildResult build_kd_rebuild(std::span<const Triangle> triangles, const Aabb& cell,
                               const BuildConfig& config, const SplitPredictor& predictor,
                               std::vector<GoldenNodeRecord>& records);

// The shape of a finished tree, for the next frame's build_kd_rebuild.
std::vector<ShapeNode> kd_shape(const KdTree& tree);

}  // namespace splitray

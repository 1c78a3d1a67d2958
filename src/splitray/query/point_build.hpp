#pragma once
// The point kd-tree builder shared by the vvh, sah and median split choosers (internal).
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "splitray/core/aabb.hpp"
#include "splitray/query/point_tree_config.hpp"

namespace splitray {

struct PointBuildOutput {
  std::vector<PointNode> nodes;  // depth first; node 0 is the root
  std::vector<std::uint32_t> permutation;
  std::optional<double> inference_ms;  // builder neural: the greedy top inference
  int top_depth = 0;                   // builder neural: levels of the inferred top
};

// `bounds` is the points' bounding box (the root cell); `radius` the resolved VVH expansion.
// Throws Error on an unknown builder name.
PointBuildOutput build_point_tree(std::span<const Vec3> points, const Aabb& bounds,
                                  const PointTreeConfig& config, float radius);

// The weight of a cell in Eq. 6: its volume grown by `radius` on every side.
double vvh_cell_volume(const Aabb& cell, float radius);

// Paper 003 Eq. 4 + 6 evaluated on a finished tree: every node weighted by the volume of its
// cell (expanded by `radius`) relative to the root's; interior nodes cost c_t, leaves c_i N.
double vvh_tree_cost(std::span<const PointNode> nodes, const Aabb& bounds,
                     const PointTreeConfig& config, float radius);

}  // namespace splitray

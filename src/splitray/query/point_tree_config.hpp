#pragma once
// What a point kd-tree is made of and how it is built: the settings and the node format,
// shared by the tree (point_tree.hpp) and its builders (point_build.hpp,
// neural_point_build.hpp), which do not depend on the tree's queries.
#include <cstdint>
#include <string>

#include "splitray/accel/neural/neural_config.hpp"

namespace splitray {

// Deepest tree: the query stack is fixed; builders respect this.
inline constexpr int kPointTreeMaxDepth = 120;

struct PointTreeConfig {
  std::string builder = "vvh";  // vvh | sah | median
  // A node with this many points or fewer becomes a leaf; VVH/SAH also stop where splitting
  // costs more than the leaf (Eq. 4), for nodes of up to 1024 points.
  int leaf_size = 10;
  // VVH/SAH: cells are expanded by this radius on every side (paper 003: the search radius;
  // 1e-4 for general neighbourhoods). <= 0: automatic, 1e-4 × the bounding-box diagonal.
  float radius = 0;
  float traversal_cost = 1.2f;  // c_t of paper 003 §6.3
  float point_cost = 1.0f;      // c_i
  // builder "neural" (paper 003): the model (empty = the shipped models/vvh.bin), the builder
  // of the inferred top's leaf cells (empty = vvh), the top's smallest node in points.
  NeuralConfig neural{};
};

// Interior: the points below have coordinate[axis] <= below_max < above_min <= the points
// above; the below child follows this node, the above child is `index` nodes further on.
// Leaf: points permutation[index, index + count); count 0 for the empty side of an
// empty-space cut (the neural builder's expanded top cells, neural_point_build.cpp).
struct PointNode {
  float below_max = 0;
  float above_min = 0;
  std::uint32_t index = 0;
  std::uint32_t bits = 3;  // low 2 bits: axis, 3 = leaf; leaf count in the upper 30 bits

  bool is_leaf() const { return (bits & 3u) == 3u; }
  int axis() const { return static_cast<int>(bits & 3u); }
  std::uint32_t count() const { return bits >> 2; }
};
static_assert(sizeof(PointNode) == 16);

}  // namespace splitray

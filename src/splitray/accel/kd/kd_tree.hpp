#pragma once
// The built kd-tree as plain data: compact 8-byte nodes laid out depth first (the below child
// of an interior node is the next node), and the primitive references of the leaves.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/core/aabb.hpp"

namespace splitray {

// pbrt-style node: the low 2 bits of `bits` hold the split axis (3 = leaf), the upper 30 bits
// the index of the above child (interior) or the primitive count (leaf).
struct KdNode {
  union {
    float split;                // interior
    std::uint32_t prim_offset;  // leaf: first reference in KdTree::prim_ids
  };
  std::uint32_t bits;

  static constexpr std::uint32_t kLeaf = 3;
  static constexpr std::uint32_t kMaxIndex = (1u << 30) - 1;

  static KdNode interior(int axis, float split_position, std::uint32_t above) {
    KdNode n;
    n.split = split_position;
    n.bits = (above << 2) | static_cast<std::uint32_t>(axis);
    return n;
  }
  static KdNode leaf(std::uint32_t offset, std::uint32_t count) {
    KdNode n;
    n.prim_offset = offset;
    n.bits = (count << 2) | kLeaf;
    return n;
  }

  bool is_leaf() const { return (bits & 3u) == kLeaf; }
  int axis() const { return static_cast<int>(bits & 3u); }
  std::uint32_t above() const { return bits >> 2; }  // interior
  std::uint32_t count() const { return bits >> 2; }  // leaf
};
static_assert(sizeof(KdNode) == 8);

struct KdTree {
  Aabb bounds;                          // the root cell
  std::vector<KdNode> nodes;            // nodes[0] = root
  std::vector<std::uint32_t> prim_ids;  // leaf references, leaf after leaf
};

// Throws Error naming `what` when `value` exceeds the 8-byte node format (2^30 - 1).
void check_kd_index(std::size_t value, const char* what);

// Node counts, depths, references and the shared SAH cost (sah_cost.hpp) of the tree's cells,
// with K_T and K_I from `config`. Leaves accel, builder, build_ms and cost_evals to the caller.
AccelStats kd_tree_stats(const KdTree& tree, const BuildConfig& config);

}  // namespace splitray

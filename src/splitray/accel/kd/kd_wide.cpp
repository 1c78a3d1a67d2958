#include "splitray/accel/kd/kd_wide.hpp"

#include <limits>

#include "splitray/core/errors.hpp"

namespace splitray {

namespace {

struct Regroup {
  const KdTree& tree;
  KdWideTree& wide;

  // The reference of binary node `index` as a cell's child.
  std::uint32_t ref(std::uint32_t index, int depth) {
    const KdNode& node = tree.nodes[index];
    if (node.is_leaf()) {
      if (node.count() == 0) return KdWideTree::kEmpty;
      wide.leaves.push_back({node.prim_offset, node.count()});
      if (node.count() < KdWideTree::kIndirect && node.prim_offset < KdWideTree::kFieldLimit)
        return KdWideTree::kLeafRef | node.prim_offset << KdWideTree::kCountBits | node.count();
      const std::size_t index = wide.leaves.size() - 1;
      if (index + 1 >= KdWideTree::kFieldLimit)
        throw Error("kd-tree", "too many leaves for the wide layout");
      return KdWideTree::kLeafRef | static_cast<std::uint32_t>(index) << KdWideTree::kCountBits |
             KdWideTree::kIndirect;
    }
    const std::size_t at = wide.nodes.size();
    if (at >= KdWideTree::kLeafRef) throw Error("kd-tree", "too many nodes for the wide layout");
    wide.nodes.emplace_back();
    if (depth + 1 > wide.max_depth) wide.max_depth = depth + 1;
    KdWideNode filled{};
    filled.meta = KdWideNode::kMetaBase;
    fill(filled, 0, 0, 0, index, true, depth);
    wide.nodes[at] = filled;
    return static_cast<std::uint32_t>(at);
  }

  // Plane `plane` (heap order) of level `level`, whose cells start at `cell`, from binary node
  // `index`; `real` false: the region is empty above a virtual plane (no binary node).
  void fill(KdWideNode& out, int plane, int level, int cell, std::uint32_t index, bool real,
            int depth) {
    const KdNode* node = real ? &tree.nodes[index] : nullptr;
    const bool interior = node && !node->is_leaf();
    out.split[plane] = interior ? node->split : std::numeric_limits<float>::infinity();
    out.meta |= static_cast<std::uint32_t>(interior ? node->axis() : 0) << (2 * plane);
    const int half = 4 >> level;  // cells under each side of this plane
    for (int side = 0; side < 2; ++side) {
      // Below a virtual plane lies the whole region (the leaf or the empty region itself).
      const bool child_real = interior ? true : (side == 0 && real);
      const std::uint32_t child = interior ? (side == 0 ? index + 1 : node->above()) : index;
      const int child_cell = cell + side * half;
      if (level < 2) {
        fill(out, 2 * plane + 1 + side, level + 1, child_cell, child, child_real, depth);
      } else {
        out.child[child_cell] = child_real ? ref(child, depth + 1) : KdWideTree::kEmpty;
        if (out.child[child_cell] != KdWideTree::kEmpty)
          out.meta |= 1u << (KdWideNode::kOccupiedShift + child_cell);
      }
    }
  }
};

}  // namespace

KdWideTree KdWideTree::from(const KdTree& tree) {
  KdWideTree wide;
  if (tree.nodes.empty()) return wide;
  // Capacities that are never exceeded, so each array is mapped once: a wide node holds at
  // least one interior node, and a leaf entry is made per non-empty leaf. (Pages beyond the
  // final size are never touched, so the excess costs address space only.)
  std::size_t interiors = 0, leaves = 0;
  for (const KdNode& node : tree.nodes) {
    interiors += !node.is_leaf();
    leaves += node.is_leaf() && node.count() > 0;
  }
  wide.nodes.reserve(interiors + 1);
  wide.leaves.reserve(leaves);
  Regroup regroup{tree, wide};
  wide.root = regroup.ref(0, 0);
  return wide;
}

}  // namespace splitray

#pragma once
// The kd-tree regrouped for single-ray traversal: every node holds three levels of the binary
// tree (7 split planes in heap order, 8 cells), so one step clips the ray against 7 planes at
// once in SIMD instead of taking 3 dependent steps, and empty cells are never visited.
//
// The cells of a node: cell c = b0 b1 b2 (bits, 1 = above the plane of that level); the plane
// of level 0 is plane 0, of level 1 plane 1 + b0, of level 2 plane 3 + 2 b0 + b1. A leaf of the
// binary tree above level 3 is padded with virtual planes at +infinity (all space below them),
// so it fills exactly one cell. The clipping of the ray is the binary traversal's, operation
// for operation, so each cell gets the interval the binary traversal would give it.
#include <cstdint>
#include <vector>

#include "splitray/accel/kd/kd_tree.hpp"
#include "splitray/core/huge_page_allocator.hpp"

namespace splitray {

// One cache line. `meta` fills the eighth split lane: bits 2p..2p+1 the axis of plane p,
// bits 14..21 the occupied cells (bit 14 + c: cell c is not empty), and bit 30 set so that the
// lane, read as a float, is a normal number (no slow denormal arithmetic on it).
struct alignas(64) KdWideNode {
  float split[7];          // planes 0..6 in heap order
  std::uint32_t meta;      // axes and occupied cells
  std::uint32_t child[8];  // per cell: a node index, kLeafRef | leaf index, or kEmpty

  static constexpr std::uint32_t kMetaBase = 1u << 30;
  static constexpr int kOccupiedShift = 14;
  int axis(int plane) const { return static_cast<int>((meta >> (2 * plane)) & 3u); }
  unsigned occupied() const { return (meta >> kOccupiedShift) & 0xffu; }
};
static_assert(sizeof(KdWideNode) == 64);

struct KdWideLeaf {
  std::uint32_t first, count;  // range of KdTree::prim_ids
};

struct KdWideTree {
  // A cell's child: a node index; kEmpty; or kLeafRef | first << 5 | count for a leaf of fewer
  // than 31 triangles whose references start below 2^26 (read without touching `leaves`: one
  // dependent load less per leaf a ray visits), else kLeafRef | index << 5 | 31 (see `leaves`).
  static constexpr std::uint32_t kLeafRef = 1u << 31;
  static constexpr std::uint32_t kEmpty = ~0u;
  static constexpr std::uint32_t kCountBits = 5, kIndirect = (1u << kCountBits) - 1;
  static constexpr std::uint32_t kFieldLimit = 1u << (31 - kCountBits);

  HugePageVector<KdWideNode> nodes;
  HugePageVector<KdWideLeaf> leaves;
  std::uint32_t root = kEmpty;  // a node, a leaf or empty
  int max_depth = 0;            // wide levels from the root to the deepest node

  // The regrouped `tree` (same cells, same leaves).
  static KdWideTree from(const KdTree& tree);
  // The leaf a child reference (with kLeafRef set) stands for.
  static KdWideLeaf leaf(std::uint32_t ref, const KdWideLeaf* leaves) {
    const std::uint32_t count = ref & kIndirect, field = (ref & ~kLeafRef) >> kCountBits;
    return count != kIndirect ? KdWideLeaf{field, count} : leaves[field];
  }
};

}  // namespace splitray

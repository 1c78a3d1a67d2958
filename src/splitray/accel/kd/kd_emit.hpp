#pragma once
// The builders write their trees straight into compact nodes instead of a pointer tree
// (a build makes hundreds of thousands of nodes; one heap node each cost as much as the
// split search of golden's or binned's nodes, and sah built 1.4x faster without them). A sequential subtree appends to a KdChunk, depth first; the few large
// nodes built as parallel tasks form a small KdPartial tree whose leaves are chunks, and
// assemble_kd lays the whole out depth first, exactly as flatten_kd would: the tree depends
// only on the build decisions, never on the thread count.
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "splitray/accel/kd/kd_tree.hpp"

namespace splitray {

// A depth-first run of nodes whose above() indices count from the chunk's first node and
// whose leaves' offsets count from the chunk's first reference.
struct KdChunk {
  std::vector<KdNode> nodes;
  std::vector<std::uint32_t> prims;

  // Reserves an interior node; finish it with set_interior once its below subtree is written.
  std::size_t open_interior() {
    nodes.push_back(KdNode::leaf(0, 0));
    return nodes.size() - 1;
  }
  // The above child is the next node written.
  void set_interior(std::size_t index, int axis, float split) {
    nodes[index] = KdNode::interior(axis, split, static_cast<std::uint32_t>(nodes.size()));
  }
  template <typename Ids>
  void add_leaf(const Ids& ids) {
    nodes.push_back(KdNode::leaf(static_cast<std::uint32_t>(prims.size()),
                                 static_cast<std::uint32_t>(ids.size())));
    prims.insert(prims.end(), ids.begin(), ids.end());
  }
};

// The top of a parallel build: an interior node with two parts, or a chunk.
struct KdPartial {
  int axis = -1;  // -1: `chunk` holds this subtree
  float split = 0;
  std::unique_ptr<KdPartial> below, above;
  KdChunk chunk;
};

// Lays out `top` depth first (below child next to its parent). Throws Error when the tree
// exceeds the node format.
KdTree assemble_kd(KdPartial& top, const Aabb& bounds);

}  // namespace splitray

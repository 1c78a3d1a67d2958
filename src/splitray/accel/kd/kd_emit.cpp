#include "splitray/accel/kd/kd_emit.hpp"

namespace splitray {

namespace {

std::size_t count_nodes(const KdPartial& p, std::size_t& prims) {
  if (p.axis < 0) {
    prims += p.chunk.prims.size();
    return p.chunk.nodes.size();
  }
  return 1 + count_nodes(*p.below, prims) + count_nodes(*p.above, prims);
}

void emit(KdPartial& p, KdTree& tree) {
  if (p.axis < 0) {
    const auto base = static_cast<std::uint32_t>(tree.nodes.size());
    const auto prim_base = static_cast<std::uint32_t>(tree.prim_ids.size());
    for (const KdNode& n : p.chunk.nodes)
      tree.nodes.push_back(n.is_leaf() ? KdNode::leaf(n.prim_offset + prim_base, n.count())
                                       : KdNode::interior(n.axis(), n.split, n.above() + base));
    tree.prim_ids.insert(tree.prim_ids.end(), p.chunk.prims.begin(), p.chunk.prims.end());
    p.chunk = {};
    return;
  }
  const std::size_t index = tree.nodes.size();
  tree.nodes.push_back(KdNode::leaf(0, 0));
  emit(*p.below, tree);
  tree.nodes[index] =
      KdNode::interior(p.axis, p.split, static_cast<std::uint32_t>(tree.nodes.size()));
  emit(*p.above, tree);
}

}  // namespace

KdTree assemble_kd(KdPartial& top, const Aabb& bounds) {
  std::size_t prims = 0;
  const std::size_t nodes = count_nodes(top, prims);
  check_kd_index(nodes, "nodes");
  check_kd_index(prims, "primitive references");
  KdTree tree;
  tree.bounds = bounds;
  tree.nodes.reserve(nodes);
  tree.prim_ids.reserve(prims);
  emit(top, tree);
  return tree;
}

}  // namespace splitray

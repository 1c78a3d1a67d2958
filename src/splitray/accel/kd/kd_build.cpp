// Flattening a builder's pointer tree into compact nodes (kd_build.hpp).
#include "splitray/accel/kd/kd_build.hpp"

#include "splitray/core/errors.hpp"

namespace splitray {

namespace {

void flatten(const KdBuildNode& node, KdTree& tree) {
  if (node.axis < 0) {
    check_kd_index(tree.prim_ids.size(), "primitive references");
    check_kd_index(node.prims.size(), "primitives in one leaf");
    tree.nodes.push_back(KdNode::leaf(static_cast<std::uint32_t>(tree.prim_ids.size()),
                                      static_cast<std::uint32_t>(node.prims.size())));
    tree.prim_ids.insert(tree.prim_ids.end(), node.prims.begin(), node.prims.end());
    return;
  }
  if (!node.below || !node.above || node.axis > 2)
    throw Error("kd-tree", "a builder produced an interior node without two children");
  const std::size_t index = tree.nodes.size();
  tree.nodes.push_back(KdNode::interior(node.axis, node.split, 0));
  flatten(*node.below, tree);
  check_kd_index(tree.nodes.size(), "nodes");
  tree.nodes[index] =
      KdNode::interior(node.axis, node.split, static_cast<std::uint32_t>(tree.nodes.size()));
  flatten(*node.above, tree);
}

}  // namespace

KdTree flatten_kd(const KdBuildNode& root, const Aabb& bounds) {
  KdTree tree;
  tree.bounds = bounds;
  flatten(root, tree);
  return tree;
}

KdTree take_kd_tree(KdBuildResult& built, const Aabb& bounds) {
  if (built.tree) {
    KdTree tree = std::move(*built.tree);
    built.tree.reset();
    return tree;
  }
  if (!built.root) throw Error("kd-tree", "the builder returned no tree");
  KdTree tree = flatten_kd(*built.root, bounds);
  built.root.reset();
  return tree;
}

}  // namespace splitray

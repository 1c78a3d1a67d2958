#include "splitray/accel/kd/kd_tree.hpp"

#include <algorithm>
#include <string>

#include "splitray/accel/kd/kd_sah.hpp"
#include "splitray/accel/sah_cost.hpp"
#include "splitray/core/errors.hpp"

namespace splitray {

namespace {

struct StatsWalk {
  const KdTree& tree;
  SahCost cost;
  AccelStats stats;
  double leaf_depth_sum = 0;

  void visit(std::uint32_t index, const Aabb& box, int depth) {
    const KdNode& node = tree.nodes[index];
    stats.max_depth = std::max(stats.max_depth, depth);
    if (node.is_leaf()) {
      ++stats.leaves;
      stats.empty_leaves += node.count() == 0 ? 1 : 0;
      stats.prim_refs += node.count();
      leaf_depth_sum += depth;
      cost.leaf(box, node.count());
      return;
    }
    cost.interior(box);
    Aabb below = box, above = box;
    below.hi[node.axis()] = node.split;
    above.lo[node.axis()] = node.split;
    visit(index + 1, below, depth + 1);
    visit(node.above(), above, depth + 1);
  }
};

}  // namespace

void check_kd_index(std::size_t value, const char* what) {
  if (value > KdNode::kMaxIndex)
    throw Error("kd-tree", std::string("too many ") + what + " for the 8-byte node format (" +
                               std::to_string(value) + " > 2^30 - 1)");
}

AccelStats kd_tree_stats(const KdTree& tree, const BuildConfig& config) {
  const SahConstants k = kd_sah(config);
  StatsWalk walk{tree, SahCost(tree.bounds, k.traversal, k.intersection), {}};
  if (!tree.nodes.empty()) walk.visit(0, tree.bounds, 0);
  AccelStats& s = walk.stats;
  s.nodes = tree.nodes.size();
  const std::size_t filled = s.leaves - s.empty_leaves;
  s.mean_leaf_prims =
      filled > 0 ? static_cast<double>(s.prim_refs) / static_cast<double>(filled) : 0.0;
  s.mean_leaf_depth = s.leaves > 0 ? walk.leaf_depth_sum / static_cast<double>(s.leaves) : 0.0;
  s.bytes = tree.nodes.size() * sizeof(KdNode) + tree.prim_ids.size() * sizeof(std::uint32_t);
  walk.cost.report(s);
  return s;
}

}  // namespace splitray

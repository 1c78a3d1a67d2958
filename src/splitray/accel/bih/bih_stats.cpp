// The statistics of a built BIH: node counts, depths and the shared SAH cost (sah_cost.hpp)
// of the regions the traversal knows.
#include <algorithm>
#include <vector>

#include "splitray/accel/bih/bih.hpp"
#include "splitray/accel/sah_cost.hpp"

namespace splitray {

void Bih::fill_stats(AccelStats& stats, float traversal_cost, float intersection_cost) const {
  stats.prims = stats.prim_refs = ids_.size();
  stats.bytes = nodes_.size() * sizeof(BihNode) + ids_.size() * sizeof(std::uint32_t) +
                tris_.size() * sizeof(Triangle);
  stats.nodes = stats.leaves = stats.empty_leaves = 0;
  stats.max_depth = 0;
  stats.cost_evals = cost_evals_;
  if (nodes_.empty()) return;
  // Each node's box is the region the traversal knows: the scene cut by the ancestors' planes.
  SahCost cost(scene_, traversal_cost, intersection_cost);
  struct Item {
    std::uint32_t node;
    int depth;
    Aabb region;
  };
  std::vector<Item> stack{{0, 0, scene_}};
  double depth_sum = 0;
  while (!stack.empty()) {
    const Item item = stack.back();
    stack.pop_back();
    const BihNode& n = nodes_[item.node];
    ++stats.nodes;
    stats.max_depth = std::max(stats.max_depth, item.depth);
    if (n.leaf()) {
      ++stats.leaves;
      if (n.count() == 0) ++stats.empty_leaves;
      depth_sum += item.depth;
      cost.leaf(item.region, n.count());
      continue;
    }
    cost.interior(item.region);
    const int a = n.axis();
    Aabb first = item.region, second = item.region;
    if (n.one_child()) {
      first.lo[a] = std::max(first.lo[a], n.clip[0]);
      first.hi[a] = std::min(first.hi[a], n.clip[1]);
      stack.push_back({n.child(), item.depth + 1, first});
      continue;
    }
    first.hi[a] = std::min(first.hi[a], n.clip[0]);
    second.lo[a] = std::max(second.lo[a], n.clip[1]);
    stack.push_back({n.child() + 1, item.depth + 1, second});
    stack.push_back({n.child(), item.depth + 1, first});
  }
  stats.mean_leaf_depth = depth_sum / static_cast<double>(stats.leaves);
  stats.mean_leaf_prims =
      static_cast<double>(stats.prim_refs) /
      static_cast<double>(std::max<std::size_t>(stats.leaves - stats.empty_leaves, 1));
  cost.report(stats);
}

}  // namespace splitray

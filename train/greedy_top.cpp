#include "greedy_top.hpp"

#include <algorithm>
#include <functional>

#include "splitray/core/errors.hpp"

namespace splitray::train {

double normalised_top_cost(const NeuralTop& top, std::span<const Vec3> samples,
                           const NeuralTopOptions& options) {
  if (top.nodes.empty()) return 1;
  const double ct = options.traversal_cost, ci = options.intersection_cost;
  const double scale = neural_sample_scale(samples.size(), options);
  // Counts from the samples themselves (not the nodes' fields), so any top is costed alike.
  std::vector<double> count(top.nodes.size(), 0);
  for (const Vec3& p : samples) {
    if (!top.nodes[0].box.contains(p)) continue;
    std::size_t n = 0;
    ++count[n];
    while (!top.nodes[n].leaf()) {
      const NeuralTopNode& node = top.nodes[n];
      n = static_cast<std::size_t>(node.child[p[node.axis] < node.split ? 0 : 1]);
      ++count[n];
    }
  }
  const std::function<double(std::size_t)> cost = [&](std::size_t n) -> double {
    const NeuralTopNode& node = top.nodes[n];
    if (node.leaf()) return ci * scale * count[n];
    const double parent = neural_cell_measure(node.box, options.cost, options.radius);
    const auto l = static_cast<std::size_t>(node.child[0]),
               r = static_cast<std::size_t>(node.child[1]);
    return ct + (neural_cell_measure(top.nodes[l].box, options.cost, options.radius) * cost(l) +
                 neural_cell_measure(top.nodes[r].box, options.cost, options.radius) * cost(r)) /
                    parent;
  };
  const double root_leaf = ci * scale * count[0];
  return root_leaf > 0 ? cost(0) / root_leaf : 1;
}

}  // namespace splitray::train

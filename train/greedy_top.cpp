#include "greedy_top.hpp"

#include <algorithm>
#include <functional>

#include "splitray/core/errors.hpp"

namespace splitray::train {

NeuralTop greedy_top(std::span<const Vec3> samples, const Aabb& root,
                     const NeuralTopOptions& options) {
  if (options.max_depth < 0) throw Error("greedy_top", "max_depth must not be negative");
  const double scale = neural_sample_scale(samples.size(), options);
  const double ci = options.intersection_cost;
  NeuralTop top;
  top.nodes.push_back({});
  top.nodes[0].box = root;
  std::vector<std::vector<std::uint32_t>> active(1);
  for (std::size_t i = 0; i < samples.size(); ++i)
    if (root.contains(samples[i])) active[0].push_back(static_cast<std::uint32_t>(i));
  top.nodes[0].samples = static_cast<std::uint32_t>(active[0].size());

  std::vector<std::size_t> frontier = {0}, next;
  std::vector<float> coords;
  for (int level = 0; level < options.max_depth && !frontier.empty(); ++level) {
    next.clear();
    for (const std::size_t n : frontier) {
      const Aabb box = top.nodes[n].box;
      const std::vector<std::uint32_t> pts = std::move(active[n]);
      const double parent = neural_cell_measure(box, options.cost, options.radius);
      if (pts.size() < 2 || !(parent > 0)) continue;
      double best = ci * static_cast<double>(pts.size()) * scale;
      int best_axis = -1;
      float best_split = 0;
      for (int axis = 0; axis < 3; ++axis) {
        coords.clear();
        for (const std::uint32_t p : pts) coords.push_back(samples[p][axis]);
        std::sort(coords.begin(), coords.end());
        // Split at each distinct sample coordinate strictly inside the cell: `below` points
        // lie below it (coordinate < split, as in inference).
        for (std::size_t i = 1; i < coords.size(); ++i) {
          if (coords[i] == coords[i - 1]) continue;
          const float split = coords[i];
          if (!(split > box.lo[axis] && split < box.hi[axis])) continue;
          const double cost =
              neural_split_cost(box, axis, split, i, coords.size(), parent, scale, options);
          if (cost < best) {
            best = cost;
            best_axis = axis;
            best_split = split;
          }
        }
      }
      if (best_axis < 0) continue;
      split_neural_top_node(top, n, best_axis, best_split, pts, samples, active, next);
      top.depth = level + 1;
    }
    std::swap(frontier, next);
  }
  return top;
}

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

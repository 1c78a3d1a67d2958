#include "splitray/accel/neural/neural_top.hpp"

#include <algorithm>
#include <cmath>
#include <ctime>

#include "splitray/core/errors.hpp"
#include "splitray/core/timer.hpp"

namespace splitray {

namespace {

double thread_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}

// The cheapest of a node's candidate splits, starting from the leaf's cost (Eq. 4, q): what
// greedy inference and the greedy top both keep.
struct CheapestSplit {
  double cost;
  int axis = -1;
  float split = 0;
  void offer(double c, int a, float s) {
    if (c < cost) cost = c, axis = a, split = s;
  }
};

}  // namespace

double neural_cell_measure(const Aabb& box, NeuralCost cost, float radius) {
  if (box.empty()) return 0;
  const Vec3 e = box.extent();
  if (cost == NeuralCost::sah)
    return static_cast<double>(e.x) * e.y + static_cast<double>(e.y) * e.z +
           static_cast<double>(e.z) * e.x;
  const double r2 = 2.0 * std::max(0.0f, radius);
  return (e.x + r2) * (e.y + r2) * (e.z + r2);
}

double neural_sample_scale(std::size_t samples, const NeuralTopOptions& options) {
  return options.population > 0 && samples > 0 ? options.population / static_cast<double>(samples)
                                               : 1.0;
}

double neural_split_cost(const Aabb& box, int axis, float split, std::size_t below,
                         std::size_t total, double parent, double scale,
                         const NeuralTopOptions& options) {
  Aabb left = box, right = box;
  left.hi[axis] = split;
  right.lo[axis] = split;
  return options.traversal_cost +
         options.intersection_cost * scale *
             (neural_cell_measure(left, options.cost, options.radius) * static_cast<double>(below) +
              neural_cell_measure(right, options.cost, options.radius) *
                  static_cast<double>(total - below)) /
             parent;
}

void split_neural_top_node(NeuralTop& top, std::size_t n, int axis, float split,
                           std::span<const std::uint32_t> pts, std::span<const Vec3> samples,
                           std::vector<std::vector<std::uint32_t>>& active,
                           std::vector<std::size_t>& next) {
  std::vector<std::uint32_t> below, above;
  for (const std::uint32_t p : pts) (samples[p][axis] < split ? below : above).push_back(p);
  const auto first = static_cast<std::int32_t>(top.nodes.size());
  NeuralTopNode& node = top.nodes[n];
  node.axis = axis;
  node.split = split;
  node.child[0] = first;
  node.child[1] = first + 1;
  Aabb left = node.box, right = node.box;  // copies: top.nodes grows below
  left.hi[axis] = split;
  right.lo[axis] = split;
  for (const Aabb& cell : {left, right}) {
    top.nodes.push_back({});
    top.nodes.back().box = cell;
    next.push_back(top.nodes.size() - 1);
  }
  top.nodes[static_cast<std::size_t>(first)].samples = static_cast<std::uint32_t>(below.size());
  top.nodes[static_cast<std::size_t>(first) + 1].samples = static_cast<std::uint32_t>(above.size());
  active.resize(top.nodes.size());
  active[static_cast<std::size_t>(first)] = std::move(below);
  active[static_cast<std::size_t>(first) + 1] = std::move(above);
}

std::size_t NeuralTop::leaves() const {
  std::size_t n = 0;
  for (const NeuralTopNode& node : nodes) n += node.leaf() ? 1 : 0;
  return n;
}

NeuralTop infer_neural_top(const NeuralModel& model, std::span<const Vec3> samples,
                           const Aabb& root, const NeuralTopOptions& options) {
  if (model.levels.empty()) throw Error("--model", "the neural model has no levels");
  if (root.empty()) throw Error("--builder neural", "the input has empty bounds");
  const Timer timer;
  const double cpu_start = thread_cpu_ms();
  const int depth =
      options.max_depth > 0 ? std::min(options.max_depth, model.depth()) : model.depth();
  if (options.greedy) {
    NeuralTopOptions sweep = options;
    sweep.max_depth = depth;
    NeuralTop top = greedy_top(samples, root, sweep);
    top.inference_ms = timer.ms();
    top.inference_cpu_ms = thread_cpu_ms() - cpu_start;
    return top;
  }
  const double scale = neural_sample_scale(samples.size(), options);
  const double ci = options.intersection_cost;

  NeuralTop top;
  std::vector<std::vector<std::uint32_t>> active(1);  // sample indices per node
  top.nodes.push_back({});
  top.nodes[0].box = root;
  for (std::size_t i = 0; i < samples.size(); ++i)
    if (root.contains(samples[i])) active[0].push_back(static_cast<std::uint32_t>(i));
  top.nodes[0].samples = static_cast<std::uint32_t>(active[0].size());

  // Level by level: every node and axis of a level goes through the level's encoder in one
  // batch (encode_groups), then each node picks its axis or stays a leaf.
  std::vector<std::size_t> frontier = {0}, next, offsets, candidates;
  std::vector<Aabb> tight;
  std::vector<float> coords, lambdas, scratch;
  for (int level = 0; level < depth && !frontier.empty(); ++level) {
    candidates.clear();
    tight.clear();
    coords.clear();
    offsets.assign(1, 0);
    for (const std::size_t n : frontier) {
      const std::vector<std::uint32_t>& pts = active[n];
      if (pts.size() < 2 ||
          static_cast<double>(pts.size()) * scale < options.min_split_population ||
          !(neural_cell_measure(top.nodes[n].box, options.cost, options.radius) > 0))
        continue;
      Aabb t;
      for (const std::uint32_t p : pts) t.extend(samples[p]);
      candidates.push_back(n);
      tight.push_back(t);
      for (int axis = 0; axis < 3; ++axis) {
        const float lo = t.lo[axis], extent = t.hi[axis] - lo;
        if (extent > 0)  // else all active points on one plane: nothing to split, no input
          for (const std::uint32_t p : pts)
            coords.push_back(std::clamp(1.0f + (samples[p][axis] - lo) / extent, 1.0f, 2.0f));
        offsets.push_back(coords.size());
      }
    }
    lambdas.resize(offsets.size() - 1);
    encode_groups(model.levels[static_cast<std::size_t>(level)], model.pooling, coords, offsets,
                  lambdas, scratch);

    next.clear();
    for (std::size_t c = 0; c < candidates.size(); ++c) {
      const std::size_t n = candidates[c];
      const Aabb box = top.nodes[n].box;  // copies: top.nodes grows below
      const std::vector<std::uint32_t> pts = std::move(active[n]);
      active[n].clear();
      const double parent = neural_cell_measure(box, options.cost, options.radius);
      CheapestSplit best{ci * static_cast<double>(pts.size()) * scale};
      for (int axis = 0; axis < 3; ++axis) {
        const float lo = tight[c].lo[axis], extent = tight[c].hi[axis] - lo;
        if (!(extent > 0)) continue;
        const float lambda =
            std::clamp(lambdas[3 * c + static_cast<std::size_t>(axis)], 0.0f, 1.0f);
        const float split = lo + lambda * extent;  // Eq. 7/14 with the tight bounds
        if (!(split > box.lo[axis] && split < box.hi[axis])) continue;
        std::size_t below = 0;
        for (const std::uint32_t p : pts) below += samples[p][axis] < split ? 1 : 0;
        best.offer(neural_split_cost(box, axis, split, below, pts.size(), parent, scale, options),
                   axis, split);
      }
      if (best.axis < 0) continue;
      split_neural_top_node(top, n, best.axis, best.split, pts, samples, active, next);
      top.depth = level + 1;
    }
    std::swap(frontier, next);
  }
  top.inference_ms = timer.ms();
  top.inference_cpu_ms = thread_cpu_ms() - cpu_start;
  return top;
}

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
      if (pts.size() < 2 || !(parent > 0) ||
          static_cast<double>(pts.size()) * scale < options.min_split_population)
        continue;
      CheapestSplit best{ci * static_cast<double>(pts.size()) * scale};
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
          best.offer(neural_split_cost(box, axis, split, i, coords.size(), parent, scale, options),
                     axis, split);
        }
      }
      if (best.axis < 0) continue;
      split_neural_top_node(top, n, best.axis, best.split, pts, samples, active, next);
      top.depth = level + 1;
    }
    std::swap(frontier, next);
  }
  return top;
}

}  // namespace splitray

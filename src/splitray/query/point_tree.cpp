#include "splitray/query/point_tree.hpp"

#include <algorithm>
#include <cmath>

#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/query/batch.hpp"
#include "splitray/query/neural_point_build.hpp"
#include "splitray/query/point_build.hpp"

namespace splitray {
namespace {

// Lower bound of the distance² from q to any point of a cell, from the per-axis gaps to the
// cell. It is summed in the same order as distance_squared(), and float rounding is monotonic,
// so it never exceeds the computed distance² of a point in the cell: pruning stays exact.
inline float bound_of(float o0, float o1, float o2) { return (o0 * o0 + o1 * o1) + o2 * o2; }

// Depth-first, near child first, with a fixed stack (the tree is at most kMaxDepth deep, and
// each level pushes at most one far child). Offsets stay in three scalars updated by selects:
// an array indexed by the axis made the compiler store one float and reload two, which
// stalls store forwarding at every node.
template <typename Result>
void search(std::span<const PointNode> nodes, const std::uint32_t* perm, const Vec3* points,
            const Aabb& bounds, const Vec3& q, Result& result) {
  struct Entry {
    std::uint32_t node;
    float bound, o0, o1, o2;
  };
  Entry stack[PointTree::kMaxDepth + 2];  // + 1: the branch-free push writes one beyond
  int top = 0;
  const auto gap = [](float v, float lo, float hi) {
    return v < lo ? lo - v : (v > hi ? v - hi : 0.0f);
  };
  float o0 = gap(q.x, bounds.lo.x, bounds.hi.x), o1 = gap(q.y, bounds.lo.y, bounds.hi.y),
        o2 = gap(q.z, bounds.lo.z, bounds.hi.z);
  std::uint32_t n = 0;
  for (;;) {
    bool pruned = false;
    while (!nodes[n].is_leaf()) {
      const PointNode& node = nodes[n];
      const int a = node.axis();
      const float qa = a == 0 ? q.x : (a == 1 ? q.y : q.z);
      const float below_gap = qa - node.below_max;  // > 0: q lies above the below child
      const float above_gap = node.above_min - qa;  // > 0: q lies below the above child
      // Branch-free choice and push: the side a query takes is a coin flip to the predictor.
      const bool above_first = below_gap >= above_gap;
      const std::uint32_t below_child = n + 1, above_child = n + node.index;
      const std::uint32_t near_child = above_first ? above_child : below_child;
      const std::uint32_t far_child = above_first ? below_child : above_child;
      const float near_gap = above_first ? above_gap : below_gap;
      const float far_gap = above_first ? below_gap : above_gap;
      // far_gap > 0 (the planes never touch); the larger of two lower bounds is one too.
      const float f0 = a == 0 ? std::max(o0, far_gap) : o0;
      const float f1 = a == 1 ? std::max(o1, far_gap) : o1;
      const float f2 = a == 2 ? std::max(o2, far_gap) : o2;
      const float far_bound = bound_of(f0, f1, f2);
      stack[top] = {far_child, far_bound, f0, f1, f2};
      top += far_bound <= result.worst() ? 1 : 0;
      if (near_gap > 0) {  // q sits in the gap between the children: the near one is off too
        o0 = a == 0 ? std::max(o0, near_gap) : o0;
        o1 = a == 1 ? std::max(o1, near_gap) : o1;
        o2 = a == 2 ? std::max(o2, near_gap) : o2;
        if (bound_of(o0, o1, o2) > result.worst()) {
          pruned = true;
          break;
        }
      }
      n = near_child;
    }
    if (!pruned) {
      const PointNode& leaf = nodes[n];
      const std::uint32_t* ids = perm + leaf.index;
      const std::uint32_t count = leaf.count();
      for (std::uint32_t i = 0; i < count; ++i) {
        const std::uint32_t id = ids[i];
        result.offer(distance_squared(points[id], q), id);
      }
    }
    for (;;) {
      if (top == 0) return;
      --top;
      if (stack[top].bound <= result.worst()) break;
    }
    n = stack[top].node;
    o0 = stack[top].o0;
    o1 = stack[top].o1;
    o2 = stack[top].o2;
  }
}

// Spread a 10-bit integer so that its bits occupy every third position.
std::uint32_t spread_bits(std::uint32_t v) {
  v = (v | (v << 16)) & 0x030000FFu;
  v = (v | (v << 8)) & 0x0300F00Fu;
  v = (v | (v << 4)) & 0x030C30C3u;
  v = (v | (v << 2)) & 0x09249249u;
  return v;
}

}  // namespace

std::vector<std::uint32_t> coherent_order(std::span<const Vec3> queries) {
  const std::size_t n = queries.size();
  Aabb box;
  for (const Vec3& q : queries) box.extend(q);
  const Vec3 ext = box.extent();
  const float scale = 1023.0f / std::max(max_component(ext), 1e-30f);
  std::vector<std::uint32_t> code(n), order(n), tmp_code(n), tmp_order(n);
  parallel_chunks(n, 16384, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      std::uint32_t c = 0;
      for (int a = 0; a < 3; ++a) {
        const float t = (queries[i][a] - box.lo[a]) * scale;
        const auto cell =
            static_cast<std::uint32_t>(t > 0 ? std::min(t, 1023.0f) : 0.0f);  // NaN: 0
        c |= spread_bits(cell) << a;
      }
      code[i] = c;
      order[i] = static_cast<std::uint32_t>(i);
    }
  });
  // LSD radix sort of (code, index) in three 10-bit passes; stable, so ties keep index order.
  for (int pass = 0; pass < 3; ++pass) {
    const int shift = 10 * pass;
    std::vector<std::uint32_t> start(1025, 0);
    for (std::size_t i = 0; i < n; ++i) ++start[((code[i] >> shift) & 1023u) + 1];
    for (int d = 0; d < 1024; ++d) start[d + 1] += start[d];
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint32_t slot = start[(code[i] >> shift) & 1023u]++;
      tmp_code[slot] = code[i];
      tmp_order[slot] = order[i];
    }
    code.swap(tmp_code);
    order.swap(tmp_order);
  }
  return order;
}

std::vector<std::string> PointTree::builder_names() { return {"vvh", "sah", "median", "neural"}; }

PointTree::PointTree(std::span<const Vec3> points, const PointTreeConfig& config)
    : points_(points) {
  const Timer timer;
  check_points(points, "point tree");
  if (config.leaf_size < 1 || config.leaf_size > (1 << 20))
    throw Error("point tree", "leaf size " + std::to_string(config.leaf_size) +
                                  " is out of range (1 .. 1048576)");
  if (!(config.traversal_cost >= 0) || !(config.point_cost > 0) || !std::isfinite(config.radius))
    throw Error("point tree", "traversal cost, point cost and radius must be finite, cost > 0");
  for (const Vec3& p : points) bounds_.extend(p);
  float radius = config.radius;
  if (!(radius > 0)) {
    radius = 1e-4f * length(bounds_.extent());
    if (!(radius > 0)) radius = 1;  // all points coincide: any positive expansion works
  }
  PointBuildOutput built;
  if (config.builder == "neural") {  // paper 003: an inferred top, expanded by config.neural.expand
    NeuralPointBuild neural = build_neural_point_tree(points, bounds_, config, radius);
    neural.tree.inference_ms = neural.top.inference_ms;
    neural.tree.top_depth = neural.top.depth;
    built = std::move(neural.tree);
  } else {
    built = build_point_tree(points, bounds_, config, radius);
  }
  nodes_ = std::move(built.nodes);
  inference_ms_ = built.inference_ms;
  top_depth_ = built.top_depth;
  permutation_ = std::move(built.permutation);

  config_ = config;
  radius_ = radius;
  build_ms_ = timer.ms();
}

PointTreeStats PointTree::stats() const {
  PointTreeStats stats;
  stats.builder = config_.builder;
  stats.points = points_.size();
  stats.nodes = nodes_.size();
  stats.radius = radius_;
  stats.build_ms = build_ms_;
  stats.inference_ms = inference_ms_;
  stats.top_depth = top_depth_;
  stats.bytes = nodes_.size() * sizeof(PointNode) + permutation_.size() * sizeof(std::uint32_t);
  std::vector<std::pair<std::uint32_t, int>> stack{{0u, 0}};
  double depth_sum = 0;
  while (!stack.empty()) {
    const auto [n, depth] = stack.back();
    stack.pop_back();
    stats.max_depth = std::max(stats.max_depth, depth);
    if (nodes_[n].is_leaf()) {
      ++stats.leaves;
      depth_sum += depth;
      continue;
    }
    stack.push_back({n + 1, depth + 1});
    stack.push_back({n + nodes_[n].index, depth + 1});
  }
  stats.mean_leaf_depth = depth_sum / static_cast<double>(stats.leaves);
  stats.mean_leaf_points = static_cast<double>(points_.size()) / static_cast<double>(stats.leaves);
  stats.vvh_cost = vvh_tree_cost(nodes_, bounds_, config_, radius_);
  return stats;
}

int PointTree::knn(const Vec3& query, int k, std::span<std::uint32_t> indices,
                   std::span<float> distances) const {
  check_k(k, size(), "k-nearest search");
  check_queries({&query, 1}, "k-nearest search");
  if (indices.size() < static_cast<std::size_t>(k) ||
      distances.size() < static_cast<std::size_t>(k))
    throw Error("k-nearest search", "output spans are shorter than k");
  knn_unchecked(query, k, indices.data(), distances.data());
  return k;
}

void PointTree::knn_unchecked(const Vec3& query, int k, std::uint32_t* indices,
                              float* distances) const {
  detail::nearest_k(k, indices, distances, [&](auto& set) {
    search(nodes_, permutation_.data(), points_.data(), bounds_, query, set);
  });
}

KnnResult PointTree::knn(std::span<const Vec3> queries, int k) const {
  check_k(k, size(), "k-nearest search");
  check_queries(queries, "k-nearest search");
  KnnResult result = detail::make_knn_result(queries.size(), k);
  const std::size_t kk = static_cast<std::size_t>(k);
  detail::for_each_query(queries, coherent_order(queries), [&](std::size_t q, const Vec3& point) {
    knn_unchecked(point, k, result.indices.data() + q * kk, result.distances.data() + q * kk);
  });
  return result;
}

void PointTree::radius(const Vec3& query, float r, std::vector<std::uint32_t>& indices,
                       std::vector<float>& distances) const {
  check_radius(r, "radius search");
  check_queries({&query, 1}, "radius search");
  std::vector<detail::WithinRadius::Entry> found;
  detail::WithinRadius within{r * r, &found};
  search(nodes_, permutation_.data(), points_.data(), bounds_, query, within);
  detail::sort_found(found);
  for (const auto& e : found) {
    indices.push_back(e.index());
    distances.push_back(std::sqrt(e.d2()));
  }
}

RadiusResult PointTree::radius(std::span<const Vec3> queries, float r) const {
  check_radius(r, "radius search");
  check_queries(queries, "radius search");
  const float r2 = r * r;
  return detail::gather_radius(
      queries, coherent_order(queries), [&](std::size_t, const Vec3& point, auto& found) {
        detail::WithinRadius within{r2, &found};
        search(nodes_, permutation_.data(), points_.data(), bounds_, point, within);
      });
}

std::uint32_t PointTree::leaf_node(const Vec3& query) const {
  std::uint32_t n = 0;
  while (!nodes_[n].is_leaf()) {
    const PointNode& node = nodes_[n];
    n = query[node.axis()] < node.above_min ? n + 1 : n + node.index;
  }
  return n;
}

std::span<const std::uint32_t> PointTree::leaf_points(const Vec3& query) const {
  const PointNode& leaf = nodes_[leaf_node(query)];
  return {permutation_.data() + leaf.index, leaf.count()};
}

std::vector<std::uint32_t> PointTree::leaf_populations(std::span<const Vec3> queries) const {
  std::vector<std::uint32_t> population(queries.size());
  parallel_chunks(queries.size(), 4096, [&](std::size_t b, std::size_t e) {
    for (std::size_t q = b; q < e; ++q) population[q] = nodes_[leaf_node(queries[q])].count();
  });
  return population;
}

}  // namespace splitray

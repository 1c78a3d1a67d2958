#include "splitray/query/neural_point_build.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "splitray/accel/neural/neural_accel.hpp"
#include "splitray/accel/neural/neural_sampling.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"

namespace splitray {

namespace {

// An empty-space cut in front of an expanded leaf cell: the slab between the cell's face and
// its points' bound on `axis` (below them if `lower`) becomes an empty leaf.
struct FaceCut {
  int axis;
  bool lower;
};

// The VVH cost (Eq. 4 + 6, in units of volume, not normalised) of the chain of `cuts` made in
// order from `cell` toward `tight`, followed by `subtree` in the cell that is left.
double cut_chain_cost(std::span<const FaceCut> cuts, Aabb cell, const Aabb& tight,
                      std::span<const PointNode> subtree, const PointTreeConfig& config,
                      float radius) {
  double cost = 0;
  for (const FaceCut& c : cuts) {
    cost += config.traversal_cost * vvh_cell_volume(cell, radius);
    (c.lower ? cell.lo : cell.hi)[c.axis] = (c.lower ? tight.lo : tight.hi)[c.axis];
  }
  return cost + vvh_tree_cost(subtree, cell, config, radius) * vvh_cell_volume(cell, radius);
}

// A leaf cell of the top keeps its parent's extent on every axis but the split ones, while the
// expansion builder, like any build from scratch, starts from its points' tight box: otherwise a
// face of the cell beyond the points could never be cut (the builders only cut between points)
// and every node of the subtree touching it would keep that empty slab (a flat patch of a
// surface in a cell as tall as the model costs 15 times its tight subtree). So the subtree is
// built on the tight box and each face slab, largest first, is cut off by an empty-space cut
// where that lowers the exact cost of the whole chain and subtree.
std::vector<FaceCut> choose_face_cuts(const Aabb& cell, const Aabb& tight,
                                      std::span<const PointNode> subtree,
                                      const PointTreeConfig& config, float radius) {
  struct Slab {
    FaceCut cut;
    double share;  // of the cell's extent on that axis (grown by the radius)
  };
  std::vector<Slab> slabs;
  const Vec3 extent = cell.extent() + Vec3(2 * radius);
  for (int a = 0; a < 3; ++a) {
    if (tight.lo[a] > cell.lo[a])
      slabs.push_back({{a, true}, (tight.lo[a] - cell.lo[a]) / extent[a]});
    if (tight.hi[a] < cell.hi[a])
      slabs.push_back({{a, false}, (cell.hi[a] - tight.hi[a]) / extent[a]});
  }
  std::stable_sort(slabs.begin(), slabs.end(),
                   [](const Slab& x, const Slab& y) { return x.share > y.share; });
  std::vector<FaceCut> cuts;
  cuts.reserve(slabs.size());
  for (const Slab& s : slabs) cuts.push_back(s.cut);
  double cost = cut_chain_cost(cuts, cell, tight, subtree, config, radius);
  for (std::size_t i = 0; i < cuts.size();) {
    std::vector<FaceCut> without = cuts;
    without.erase(without.begin() + static_cast<std::ptrdiff_t>(i));
    const double c = cut_chain_cost(without, cell, tight, subtree, config, radius);
    if (c < cost) {
      cost = c;
      cuts = std::move(without);
    } else {
      ++i;
    }
  }
  return cuts;
}

struct Expander {
  std::span<const Vec3> points;
  const NeuralTop& top;
  PointTreeConfig sub;  // the expansion builder's config
  float radius;
  std::vector<std::vector<std::uint32_t>> ids;  // per top node: its points (leaves only)
  std::vector<PointBuildOutput> built;          // per top node: the leaf cell's subtree
  std::vector<Aabb> cells;                      // per top node: the cell the tree gives it
  std::vector<Aabb> tight;                      // per top leaf: its points' bounding box
  std::vector<std::vector<FaceCut>> cuts;       // per top leaf: the cuts in front of it

  // The cells as the final tree sees them: a child's cell ends at the tight bound of its points
  // on the split axis (PointNode's below_max / above_min). Returns the node's point count.
  std::size_t count(int node) {
    const NeuralTopNode& n = top.nodes[static_cast<std::size_t>(node)];
    if (n.leaf()) return ids[static_cast<std::size_t>(node)].size();
    return count(n.child[0]) + count(n.child[1]);
  }

  // Tight bounds on `axis` of the points below a top node.
  void extent(int node, int axis, float& lo, float& hi) const {
    const NeuralTopNode& n = top.nodes[static_cast<std::size_t>(node)];
    if (n.leaf()) {
      for (const std::uint32_t i : ids[static_cast<std::size_t>(node)]) {
        lo = std::min(lo, points[i][axis]);
        hi = std::max(hi, points[i][axis]);
      }
      return;
    }
    extent(n.child[0], axis, lo, hi);
    extent(n.child[1], axis, lo, hi);
  }

  // Assigns cells top-down, collapsing top nodes one of whose sides has no point (a PointNode
  // needs points on both sides), and lists the leaf cells to expand.
  void assign_cells(int node, const Aabb& cell, std::vector<int>& leaves) {
    const NeuralTopNode& n = top.nodes[static_cast<std::size_t>(node)];
    cells[static_cast<std::size_t>(node)] = cell;
    if (n.leaf()) {
      leaves.push_back(node);
      return;
    }
    const std::size_t below = count(n.child[0]), above = count(n.child[1]);
    if (below == 0 || above == 0) {
      assign_cells(below == 0 ? n.child[1] : n.child[0], cell, leaves);
      return;
    }
    float blo = cell.hi[n.axis], bhi = cell.lo[n.axis], alo = cell.hi[n.axis],
          ahi = cell.lo[n.axis];
    extent(n.child[0], n.axis, blo, bhi);
    extent(n.child[1], n.axis, alo, ahi);
    Aabb lower = cell, upper = cell;
    lower.hi[n.axis] = bhi;
    upper.lo[n.axis] = alo;
    assign_cells(n.child[0], lower, leaves);
    assign_cells(n.child[1], upper, leaves);
  }

  // Top leaf `node`: its face cuts from the k-th on, then its subtree.
  void emit_leaf(std::size_t node, std::size_t k, PointBuildOutput& out) {
    const auto offset = static_cast<std::uint32_t>(out.permutation.size());
    if (k == cuts[node].size()) {
      const PointBuildOutput& sub_tree = built[node];
      const std::vector<std::uint32_t>& local = ids[node];
      for (PointNode p : sub_tree.nodes) {
        if (p.is_leaf()) p.index += offset;  // interior indices are relative: unchanged
        out.nodes.push_back(p);
      }
      for (const std::uint32_t i : sub_tree.permutation) out.permutation.push_back(local[i]);
      return;
    }
    constexpr float kInf = std::numeric_limits<float>::infinity();
    const FaceCut cut = cuts[node][k];
    const float bound = (cut.lower ? tight[node].lo : tight[node].hi)[cut.axis];
    PointNode interior, empty;
    interior.bits = static_cast<std::uint32_t>(cut.axis);
    interior.below_max = cut.lower ? std::nextafter(bound, -kInf) : bound;
    interior.above_min = cut.lower ? bound : std::nextafter(bound, kInf);
    empty.index = offset;  // no points
    empty.bits = 3u;
    const std::size_t self = out.nodes.size();
    out.nodes.push_back(interior);
    if (cut.lower) out.nodes.push_back(empty);
    const std::size_t rest = out.nodes.size();
    emit_leaf(node, k + 1, out);
    out.nodes[self].index =
        static_cast<std::uint32_t>(cut.lower ? rest - self : out.nodes.size() - self);
    if (!cut.lower) out.nodes.push_back(empty);
  }

  void emit(int node, PointBuildOutput& out) {
    const NeuralTopNode& n = top.nodes[static_cast<std::size_t>(node)];
    if (n.leaf()) {
      emit_leaf(static_cast<std::size_t>(node), 0, out);
      return;
    }
    const std::size_t below = count(n.child[0]), above = count(n.child[1]);
    if (below == 0 || above == 0) {
      emit(below == 0 ? n.child[1] : n.child[0], out);
      return;
    }
    const Aabb& lower = cells[static_cast<std::size_t>(n.child[0])];
    const Aabb& upper = cells[static_cast<std::size_t>(n.child[1])];
    PointNode interior;
    interior.below_max = lower.hi[n.axis];
    interior.above_min = upper.lo[n.axis];
    interior.bits = static_cast<std::uint32_t>(n.axis);
    const std::size_t self = out.nodes.size();
    out.nodes.push_back(interior);
    emit(n.child[0], out);
    out.nodes[self].index = static_cast<std::uint32_t>(out.nodes.size() - self);
    emit(n.child[1], out);
  }
};

}  // namespace

NeuralTop infer_point_top(const NeuralModel& model, std::span<const Vec3> points,
                          const Aabb& bounds, const PointTreeConfig& config, float radius,
                          double* sampling_ms) {
  const Timer timer;
  const std::vector<Vec3> samples = sample_points(points, static_cast<std::size_t>(model.points));
  if (sampling_ms) *sampling_ms = timer.ms();
  NeuralTopOptions options;
  options.cost = NeuralCost::vvh;
  options.traversal_cost = config.traversal_cost;
  options.intersection_cost = config.point_cost;
  options.radius = radius;
  options.population = static_cast<double>(points.size());
  options.min_split_population = config.neural.top_min;
  options.greedy = config.neural.greedy_top;
  return infer_neural_top(model, samples, bounds, options);
}

PointBuildOutput expand_point_top(std::span<const Vec3> points, const Aabb& bounds,
                                  const NeuralTop& top, const PointTreeConfig& config,
                                  float radius) {
  Expander ex{points, top, config, radius, {}, {}, {}, {}, {}};
  ex.sub.builder = config.neural.expand.empty() ? "vvh" : config.neural.expand;
  if (ex.sub.builder == "neural") throw Error("--expand", "neural cannot expand its own top");
  ex.ids.resize(top.nodes.size());
  ex.built.resize(top.nodes.size());
  ex.cells.resize(top.nodes.size());
  ex.tight.resize(top.nodes.size());
  ex.cuts.resize(top.nodes.size());
  // Population: every point to the one leaf cell on its side of every split (below: < split).
  for (std::size_t i = 0; i < points.size(); ++i) {
    int node = 0;
    while (!top.nodes[static_cast<std::size_t>(node)].leaf()) {
      const NeuralTopNode& n = top.nodes[static_cast<std::size_t>(node)];
      node = n.child[points[i][n.axis] < n.split ? 0 : 1];
    }
    ex.ids[static_cast<std::size_t>(node)].push_back(static_cast<std::uint32_t>(i));
  }
  std::vector<int> leaves;
  ex.assign_cells(0, bounds, leaves);
  parallel_for_each_index(leaves.size(), [&](std::size_t k) {
    const auto node = static_cast<std::size_t>(leaves[k]);
    const std::vector<std::uint32_t>& ids = ex.ids[node];
    if (ids.empty()) return;  // only a lone root cell can be empty, and points exist
    std::vector<Vec3> subset;
    subset.reserve(ids.size());
    Aabb& tight = ex.tight[node];
    for (const std::uint32_t i : ids) {
      subset.push_back(points[i]);
      tight.extend(points[i]);
    }
    ex.built[node] = build_point_tree(subset, tight, ex.sub, radius);
    ex.cuts[node] = choose_face_cuts(ex.cells[node], tight, ex.built[node].nodes, ex.sub, radius);
  });
  PointBuildOutput out;
  out.nodes.reserve(4 * points.size() / std::max(1, config.leaf_size) + 16);
  out.permutation.reserve(points.size());
  ex.emit(0, out);
  if (out.permutation.size() != points.size())
    throw Error("--builder neural", "population lost points (internal error)");
  // The query stack is fixed: the top's levels add to the expanded subtrees' depth.
  std::vector<std::pair<std::uint32_t, int>> stack{{0u, 0}};
  while (!stack.empty()) {
    const auto [n, depth] = stack.back();
    stack.pop_back();
    if (depth > kPointTreeMaxDepth)
      throw Error("--builder neural",
                  "the tree is deeper than " + std::to_string(kPointTreeMaxDepth) + " levels");
    if (out.nodes[n].is_leaf()) continue;
    stack.emplace_back(n + 1, depth + 1);
    stack.emplace_back(n + out.nodes[n].index, depth + 1);
  }
  return out;
}

NeuralPointBuild build_neural_point_tree(std::span<const Vec3> points, const Aabb& bounds,
                                         const PointTreeConfig& config, float radius) {
  const NeuralModel model = load_neural_model(config.neural.model, NeuralCost::vvh);
  NeuralPointBuild out;
  out.top = infer_point_top(model, points, bounds, config, radius, &out.sampling_ms);
  out.tree = expand_point_top(points, bounds, out.top, config, radius);
  return out;
}

}  // namespace splitray

#include "splitray/accel/neural/neural_accel.hpp"

#include <algorithm>

#include "splitray/accel/bvh/bvh.hpp"
#include "splitray/accel/bvh/bvh_accel.hpp"
#include "splitray/accel/bvh/kd_top_bvh.hpp"
#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/accel/kd/kd_sah.hpp"
#include "splitray/accel/neural/model_path.hpp"
#include "splitray/accel/neural/neural_sampling.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"

namespace splitray {

namespace {

// The built structure with the neural builder's own statistics on top of the inner one's.
class NeuralAccel final : public Accel {
 public:
  NeuralAccel(std::unique_ptr<Accel> inner, AccelStats stats)
      : inner_(std::move(inner)), stats_(std::move(stats)) {}
  Hit closest_hit(const Ray& ray) const override { return inner_->intersect(ray); }
  bool any_hit(const Ray& ray) const override { return inner_->occluded(ray); }
  void closest_hits(std::span<const Ray> rays, std::span<Hit> hits) const override {
    inner_->intersect(rays, hits);
  }
  void any_hits(std::span<const Ray> rays, std::span<std::uint8_t> occluded) const override {
    inner_->occluded(rays, occluded);
  }
  const AccelStats& stats() const override { return stats_; }
  bool refit_to(std::span<const Triangle> triangles) override {
    if (!inner_->refit(triangles)) return false;
    AccelStats refitted = inner_->stats();
    refitted.builder = stats_.builder;
    refitted.inference_ms = stats_.inference_ms;
    refitted.top_depth = stats_.top_depth;
    stats_ = refitted;
    return true;
  }

 private:
  std::unique_ptr<Accel> inner_;
  AccelStats stats_;
};

bool overlaps_closed(const Aabb& a, const Aabb& b) {
  return a.lo.x <= b.hi.x && a.hi.x >= b.lo.x && a.lo.y <= b.hi.y && a.hi.y >= b.lo.y &&
         a.lo.z <= b.hi.z && a.hi.z >= b.lo.z;
}

void check_input(std::span<const Triangle> triangles, const std::string& accel) {
  if (triangles.empty()) throw Error("--accel " + accel, "no triangles to build on");
  check_triangles(triangles, "--accel " + accel);
}

Aabb bounds_of(std::span<const Triangle> triangles) {
  Aabb b;
  for (const Triangle& t : triangles) b.extend(t.bounds());
  return b;
}

// Leaf cells of the top in depth-first order, each with its level.
void collect_leaves(const NeuralTop& top, int node, int level,
                    std::vector<std::pair<int, int>>& out) {
  const NeuralTopNode& n = top.nodes[static_cast<std::size_t>(node)];
  if (n.leaf()) {
    out.emplace_back(node, level);
    return;
  }
  collect_leaves(top, n.child[0], level + 1, out);
  collect_leaves(top, n.child[1], level + 1, out);
}

// Descends a triangle's bounds through the top; appends it to every leaf cell it reaches.
void assign(const NeuralTop& top, int node, const Aabb& b, std::uint32_t id,
            std::vector<std::vector<std::uint32_t>>& per_node) {
  const NeuralTopNode& n = top.nodes[static_cast<std::size_t>(node)];
  if (n.leaf()) {
    per_node[static_cast<std::size_t>(node)].push_back(id);
    return;
  }
  if (b.lo[n.axis] <= n.split) assign(top, n.child[0], b, id, per_node);
  if (b.hi[n.axis] >= n.split) assign(top, n.child[1], b, id, per_node);
}

// Lays out the top's interior nodes depth first with each leaf cell's subtree in its place.
void stitch(const NeuralTop& top, int node, std::vector<KdTree>& subtrees, KdTree& out) {
  const NeuralTopNode& n = top.nodes[static_cast<std::size_t>(node)];
  if (n.leaf()) {
    KdTree& sub = subtrees[static_cast<std::size_t>(node)];
    const auto base = static_cast<std::uint32_t>(out.nodes.size());
    const auto prim_base = static_cast<std::uint32_t>(out.prim_ids.size());
    for (const KdNode& k : sub.nodes)
      out.nodes.push_back(k.is_leaf() ? KdNode::leaf(k.prim_offset + prim_base, k.count())
                                      : KdNode::interior(k.axis(), k.split, k.above() + base));
    out.prim_ids.insert(out.prim_ids.end(), sub.prim_ids.begin(), sub.prim_ids.end());
    sub = {};
    return;
  }
  const std::size_t self = out.nodes.size();
  out.nodes.push_back(KdNode::leaf(0, 0));
  stitch(top, n.child[0], subtrees, out);
  if (out.nodes.size() > KdNode::kMaxIndex)
    throw Error("--builder neural", "too many nodes for the kd node format");
  out.nodes[self] = KdNode::interior(n.axis, n.split, static_cast<std::uint32_t>(out.nodes.size()));
  stitch(top, n.child[1], subtrees, out);
}

std::string expand_name(const BuildConfig& config, const std::string& fallback) {
  return config.neural.expand.empty() ? fallback : config.neural.expand;
}

}  // namespace

NeuralModel load_neural_model(const std::string& path, NeuralCost cost) {
  const std::string file = path.empty() ? default_model_path(cost) : path;
  NeuralModel model = read_neural_model(file);
  if (model.cost != cost)
    throw Error(file, std::string("the model was trained for the ") +
                          (model.cost == NeuralCost::sah ? "SAH" : "VVH") +
                          " cost, this structure needs " +
                          (cost == NeuralCost::sah ? "SAH" : "VVH"));
  return model;
}

TriangleTop infer_triangle_top(const NeuralModel& model, std::span<const Triangle> triangles,
                               const Aabb& bounds, const BuildConfig& config) {
  TriangleTop out;
  const Timer timer;
  const SurfaceSampler sampler(triangles);
  const std::vector<Vec3> samples = sampler.sample(static_cast<std::size_t>(model.points));
  out.sampling_ms = timer.ms();
  NeuralTopOptions options;
  options.cost = NeuralCost::sah;
  // The constants the shipped model was trained with, unless the user gives others (the
  // top's own costing; the kd expansion below uses kd's constants, a BVH's the BVH's).
  const SahConstants k = config.sah(kSharedSah);
  options.traversal_cost = k.traversal;
  options.intersection_cost = k.intersection;
  options.population = static_cast<double>(triangles.size());
  options.min_split_population = config.neural.top_min;
  options.greedy = config.neural.greedy_top;
  out.top = infer_neural_top(model, samples, bounds, options);
  return out;
}

KdTree expand_top_kd(std::span<const Triangle> triangles, const NeuralTop& top, KdBuilder expand,
                     const BuildConfig& config, std::uint64_t* cost_evals) {
  std::vector<std::vector<std::uint32_t>> per_node(top.nodes.size());
  const Aabb& root = top.nodes[0].box;
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    const Aabb b = triangles[i].bounds();
    if (overlaps_closed(b, root)) assign(top, 0, b, static_cast<std::uint32_t>(i), per_node);
  }
  std::vector<std::pair<int, int>> leaves;
  collect_leaves(top, 0, 0, leaves);
  const int total_depth = kd_max_depth(config, triangles.size());
  std::vector<KdTree> subtrees(top.nodes.size());
  std::vector<std::uint64_t> evals(leaves.size(), 0);
  parallel_for_each_index(leaves.size(), [&](std::size_t k) {
    const auto [node, level] = leaves[k];
    const std::vector<std::uint32_t>& ids = per_node[static_cast<std::size_t>(node)];
    const Aabb& cell = top.nodes[static_cast<std::size_t>(node)].box;
    KdTree& sub = subtrees[static_cast<std::size_t>(node)];
    if (ids.empty()) {
      sub.nodes.push_back(KdNode::leaf(0, 0));
      return;
    }
    std::vector<Triangle> subset;
    subset.reserve(ids.size());
    for (const std::uint32_t id : ids) subset.push_back(triangles[id]);
    BuildConfig below = config;
    below.max_depth = std::max(1, total_depth - level);  // the same depth cap as a whole-tree build
    KdBuildResult built = expand(subset, cell, below);
    evals[k] = built.cost_evals;
    if (!built.root && !built.tree) {
      sub.nodes.push_back(KdNode::leaf(0, 0));
      return;
    }
    sub = take_kd_tree(built, cell);
    for (std::uint32_t& p : sub.prim_ids) p = ids[p];
  });
  KdTree tree;
  tree.bounds = root;
  stitch(top, 0, subtrees, tree);
  if (tree.prim_ids.size() > KdNode::kMaxIndex)
    throw Error("--builder neural", "too many primitive references for the kd node format");
  if (cost_evals)
    for (const std::uint64_t e : evals) *cost_evals += e;
  return tree;
}

std::unique_ptr<Accel> make_neural_kd(std::span<const Triangle> triangles,
                                      const BuildConfig& config) {
  check_input(triangles, "kd");
  const std::string expand = expand_name(config, kd_builder_names().front());
  if (expand == "neural") throw Error("--expand", "neural cannot expand its own top");
  const KdBuilder builder = kd_builder(expand);
  const NeuralModel model = load_neural_model(config.neural.model, NeuralCost::sah);
  const Timer timer;
  const Aabb bounds = bounds_of(triangles);
  const TriangleTop top = infer_triangle_top(model, triangles, bounds, config);
  std::uint64_t evals = 0;
  KdTree tree = expand_top_kd(triangles, top.top, builder, config, &evals);
  BuildConfig named = config;
  named.builder = "neural";
  auto inner = std::make_unique<KdAccel>(std::move(tree), triangles, named, evals, timer);
  AccelStats stats = inner->stats();
  stats.builder = (config.neural.greedy_top ? "greedy-top+" : "neural+") + expand;
  stats.inference_ms = top.top.inference_ms;
  stats.top_depth = top.top.depth;
  return std::make_unique<NeuralAccel>(std::move(inner), stats);
}

std::unique_ptr<Accel> make_neural_bvh(std::span<const Triangle> triangles,
                                       const BuildConfig& config) {
  check_input(triangles, "bvh");
  const std::string expand = expand_name(config, "binned");
  const LeafExpander expander = parse_leaf_expander(expand);
  const NeuralModel model = load_neural_model(config.neural.model, NeuralCost::sah);
  const Timer timer;
  const Aabb bounds = bounds_of(triangles);
  const TriangleTop top = infer_triangle_top(model, triangles, bounds, config);
  std::vector<TopCell> cells(top.top.nodes.size());
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const NeuralTopNode& n = top.top.nodes[i];
    cells[i].box = n.box;
    cells[i].axis = std::max(0, n.axis);
    cells[i].child[0] = n.child[0];
    cells[i].child[1] = n.child[1];
  }
  Bvh bvh = build_top_bvh(triangles, cells, expander, BvhBuildOptions::from(config));
  std::unique_ptr<Accel> inner = wrap_bvh(std::move(bvh), config, timer.ms());
  AccelStats stats = inner->stats();
  stats.build_ms = timer.ms();
  stats.accel = "bvh";
  stats.builder = (config.neural.greedy_top ? "greedy-top+" : "neural+") + expand;
  stats.inference_ms = top.top.inference_ms;
  stats.top_depth = top.top.depth;
  return std::make_unique<NeuralAccel>(std::move(inner), stats);
}

}  // namespace splitray

#include "splitray/accel/kd/kd_accel.hpp"

#include <algorithm>

#include "splitray/accel/kd/kd_sah.hpp"
#include "splitray/accel/robust_ray.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

struct NamedBuilder {
  const char* name;
  KdBuilder build;
};

constexpr NamedBuilder kBuilders[] = {
    {"sah", build_kd_sah},
    {"golden", build_kd_golden},
    {"binned", build_kd_binned},
};

// The leaves' triangle rows (KdLeafTriangles) sit at 9 x each leaf's first reference, so the
// leaves' reference ranges must tile prim_ids. Every builder emits its leaves' references in
// node order, so that is checked in one pass; a tree whose leaves share ranges or leave gaps
// gets its references copied leaf after leaf in node order (the cells stay the same).
void tile_leaf_ranges(KdTree& tree) {
  std::uint64_t next = 0;
  bool tiled = true;
  for (const KdNode& node : tree.nodes) {
    if (!node.is_leaf() || node.count() == 0) continue;
    if (std::uint64_t{node.prim_offset} + node.count() > tree.prim_ids.size())
      throw Error("--accel kd", "a leaf refers past the end of the reference list");
    tiled = tiled && node.prim_offset == next;
    next = std::uint64_t{node.prim_offset} + node.count();
  }
  if (tiled && next == tree.prim_ids.size()) return;
  std::vector<std::uint32_t> ids;
  for (KdNode& node : tree.nodes) {
    if (!node.is_leaf() || node.count() == 0) continue;
    const std::size_t first = ids.size();
    if (first + node.count() > KdNode::kMaxIndex)
      throw Error("--accel kd", "too many primitive references for the 8-byte node format");
    ids.insert(ids.end(), tree.prim_ids.begin() + node.prim_offset,
               tree.prim_ids.begin() + node.prim_offset + node.count());
    node = KdNode::leaf(static_cast<std::uint32_t>(first), node.count());
  }
  tree.prim_ids = std::move(ids);
}

}  // namespace

std::vector<std::string> kd_builder_names() {
  std::vector<std::string> names;
  for (const NamedBuilder& b : kBuilders) names.emplace_back(b.name);
  return names;
}

KdBuilder kd_builder(const std::string& name) {
  for (const NamedBuilder& b : kBuilders)
    if (name == b.name) return b.build;
  std::string known;
  for (const NamedBuilder& b : kBuilders)
    known += (known.empty() ? "" : ", ") + std::string(b.name);
  throw Error("--builder", "'" + name + "' is not a builder of --accel kd (known: " + known + ")");
}

std::unique_ptr<Accel> make_kd(std::span<const Triangle> triangles, const BuildConfig& config) {
  BuildConfig resolved = config;
  if (resolved.builder.empty()) resolved.builder = kBuilders[0].name;
  const KdBuilder builder = kd_builder(resolved.builder);
  if (triangles.empty()) throw Error("--accel kd", "no triangles to build on");
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    const Triangle& t = triangles[i];
    if (!is_finite(t.v0) || !is_finite(t.v1) || !is_finite(t.v2))
      throw Error("--accel kd",
                  "triangle " + std::to_string(i) + " has a NaN or infinite coordinate");
  }
  ThreadLimit limit(resolved.threads);
  const Timer timer;
  Aabb bounds;
  for (const Triangle& t : triangles) bounds.extend(t.bounds());
  KdBuildResult built = builder(triangles, bounds, resolved);
  if (!built.root && !built.tree)
    throw Error("--builder " + resolved.builder, "the builder returned no tree");
  KdTree tree = take_kd_tree(built, bounds);
  return std::make_unique<KdAccel>(std::move(tree), triangles, resolved, built.cost_evals, timer);
}

KdAccel::KdAccel(KdTree tree, std::span<const Triangle> triangles, const BuildConfig& config,
                 std::uint64_t cost_evals, const Timer& build_timer)
    : tree_(std::move(tree)) {
  if (tree_.nodes.empty()) throw Error("--accel kd", "the tree has no nodes");
  tile_leaf_ranges(tree_);
  for (const std::uint32_t id : tree_.prim_ids)
    if (id >= triangles.size()) throw Error("--accel kd", "a leaf refers to a missing triangle");
  // The statistics, the wide layout and the leaves' rows only read the tree: built at once.
  const auto fill_rows = [&] {
    // The leaves tile prim_ids, so each writes its own rows: in parallel, in any order.
    std::vector<KdWideLeaf> leaves;
    for (const KdNode& node : tree_.nodes)
      if (node.is_leaf() && node.count() > 0) leaves.push_back({node.prim_offset, node.count()});
    leaf_triangles_.resize(tree_.prim_ids.size());
    parallel_chunks(leaves.size(), 4096, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i)
        leaf_triangles_.set_leaf(leaves[i].first, leaves[i].count, tree_.prim_ids.data(),
                                 triangles.data());
    });
  };
  parallel_invoke([&] { stats_ = kd_tree_stats(tree_, config); },
                  [&] { wide_ = KdWideTree::from(tree_); }, fill_rows);
  // The walks' stacks hold one entry per binary level (kd packets) and 7 per wide level: every
  // builder stops at kKdDepthLimit (kd_sah.hpp), which kWideDepthLimit covers.
  if (stats_.max_depth > kKdDepthLimit)
    throw Error("--accel kd",
                "the tree is deeper than " + std::to_string(kKdDepthLimit) + " levels");
  if (wide_.max_depth > kWideDepthLimit)
    throw Error("--accel kd", "the tree is too deep for the wide layout's traversal stack");
  stats_.bytes +=
      wide_.nodes.size() * sizeof(KdWideNode) + wide_.leaves.size() * sizeof(KdWideLeaf);
  coord_scale_ = coordinate_magnitude(tree_.bounds);
  stats_.accel = "kd";
  stats_.builder = config.builder;
  stats_.prims = triangles.size();
  stats_.bytes += leaf_triangles_.bytes();
  stats_.cost_evals = cost_evals;
  interleave_ = stats_.bytes > kInterleaveBytes;
  stats_.build_ms = build_timer.ms();
}

}  // namespace splitray

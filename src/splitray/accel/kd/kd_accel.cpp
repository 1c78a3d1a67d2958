#include "splitray/accel/kd/kd_accel.hpp"

#include "splitray/accel/kd/kd_sah.hpp"
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
  if (!built.root) throw Error("--builder " + resolved.builder, "the builder returned no tree");
  KdTree tree = flatten_kd(*built.root, bounds);
  built.root.reset();
  return std::make_unique<KdAccel>(std::move(tree), triangles, resolved, built.cost_evals, timer);
}

KdAccel::KdAccel(KdTree tree, std::span<const Triangle> triangles, const BuildConfig& config,
                 std::uint64_t cost_evals, const Timer& build_timer)
    : tree_(std::move(tree)) {
  if (tree_.nodes.empty()) throw Error("--accel kd", "the tree has no nodes");
  stats_ = kd_tree_stats(tree_, config);
  if (stats_.max_depth > kKdDepthLimit)  // the traversal stack holds one entry per level
    throw Error("--accel kd",
                "the tree is deeper than " + std::to_string(kKdDepthLimit) + " levels");
  leaf_triangles_.reserve(tree_.prim_ids.size());
  for (const std::uint32_t id : tree_.prim_ids) {
    if (id >= triangles.size()) throw Error("--accel kd", "a leaf refers to a missing triangle");
    leaf_triangles_.push_back(triangles[id]);
  }
  coord_scale_ = std::max(max_component(abs(tree_.bounds.lo)), max_component(abs(tree_.bounds.hi)));
  stats_.accel = "kd";
  stats_.builder = config.builder;
  stats_.prims = triangles.size();
  stats_.bytes += leaf_triangles_.size() * sizeof(Triangle);
  stats_.cost_evals = cost_evals;
  stats_.build_ms = build_timer.ms();
}

}  // namespace splitray

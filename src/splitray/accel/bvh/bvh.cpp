#include "splitray/accel/bvh/bvh.hpp"

#include <algorithm>
#include <cmath>

#include "splitray/accel/bvh/object_split.hpp"
#include "splitray/accel/robust_ray.hpp"
#include "splitray/accel/sah_cost.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

BvhBuildOptions BvhBuildOptions::from(const BuildConfig& config) {
  BvhBuildOptions o;
  const SahConstants k = config.sah(kSharedSah);  // the BVH's defaults
  o.traversal_cost = k.traversal;
  o.intersection_cost = k.intersection;
  o.min_leaf = std::max(config.max_leaf_prims, 1);
  o.bins = std::clamp(config.bins, 4, 256);
  o.max_depth = config.max_depth > 0 ? std::min(config.max_depth, 64) : 64;
  return o;
}

std::vector<std::string> Bvh::builder_names() { return {"binned", "sbvh", "embree"}; }

Bvh Bvh::build(std::span<const Triangle> triangles, const std::string& builder,
               const BvhBuildOptions& given) {
  std::vector<BvhRef> refs = make_prim_refs(triangles);
  const RefBounds bounds = ref_bounds(refs);  // the scene's box, and the builders' root
  BvhBuildOptions options = given;
  options.measure = SplitMeasure::interior(bounds.box);
  BvhBuildResult result;
  if (builder == "binned")
    result = build_bvh_binned(triangles, std::move(refs), bounds, options);
  else if (builder == "sbvh")
    result = build_bvh_sbvh(triangles, std::move(refs), bounds, options);
  else if (builder == "embree")
    result = build_bvh_embree(triangles, std::move(refs), options, true);
  else {
    std::string known;
    for (const std::string& name : builder_names()) known += (known.empty() ? "" : ", ") + name;
    throw Error("--builder", "'" + builder + "' is not a BVH builder (known: " + known + ")");
  }
  Bvh bvh = from_pieces(triangles, *result.root);
  bvh.cost_evals_ = result.cost_evals;
  return bvh;
}

Bvh Bvh::from_pieces(std::span<const Triangle> triangles, const BvhPiece& root) {
  Bvh bvh;
  bvh.triangle_count_ = triangles.size();
  flatten_pieces<BvhNodeTraits>(root, bvh.nodes_, bvh.ids_);
  if (bvh.ids_.empty()) bvh.nodes_.clear();  // nothing to hold
  for (const std::uint32_t id : bvh.ids_)
    if (id >= triangles.size())
      throw Error("bvh", "a leaf refers to a triangle that does not exist");
  bvh.update_scene_bounds(triangles);
  bvh.wide_.collapse(bvh.nodes_, bvh.ids_, triangles);
  return bvh;
}

void Bvh::update_scene_bounds(std::span<const Triangle> triangles) {
  // Clipped boxes may be smaller than their triangles: the bounds of all triangles, read in
  // their order (in leaf order the reads missed the cache: 6 ms of a 100 ms build). Min and
  // max are exact: the same bounds for any split of the work.
  scene_ = nodes_.empty() ? Aabb{} : nodes_[0].box();
  scene_.extend(parallel_reduce(
      triangles.size(), 32768, Aabb{},
      [&](std::size_t begin, std::size_t end, Aabb& box) {
        for (std::size_t i = begin; i < end; ++i) box.extend(triangles[i].bounds());
      },
      [](Aabb& total, const Aabb& part) { total.extend(part); }));
  magnitude_ = nodes_.empty() ? 0.0f : coordinate_magnitude(scene_);
}

void Bvh::refit(std::span<const Triangle> triangles) {
  if (triangles.size() != triangle_count_)
    throw Error("bvh refit", "the deformed mesh has " + std::to_string(triangles.size()) +
                                 " triangles, the BVH was built on " +
                                 std::to_string(triangle_count_));
  // Children always come after their parent: one backward pass is bottom-up.
  for (std::size_t i = nodes_.size(); i-- > 0;) {
    BvhNode& n = nodes_[i];
    Aabb box;
    if (n.leaf()) {
      for (std::uint32_t r = n.index; r < n.index + n.count(); ++r)
        box.extend(triangles[ids_[r]].bounds());
    } else {
      box = merge(nodes_[n.index].box(), nodes_[n.index + 1].box());
    }
    n.lo = box.lo;
    n.hi = box.hi;
  }
  wide_.refit(nodes_, triangles);
  update_scene_bounds(triangles);
}

std::size_t Bvh::bytes() const {
  return nodes_.size() * sizeof(BvhNode) + wide_.bytes() + ids_.size() * sizeof(std::uint32_t);
}

void Bvh::fill_stats(AccelStats& stats, float traversal_cost, float intersection_cost) const {
  stats.prims = triangle_count_;
  stats.bytes = bytes();
  stats.prim_refs = ids_.size();
  stats.cost_evals = cost_evals_;
  stats.nodes = stats.leaves = stats.empty_leaves = 0;
  stats.max_depth = 0;
  if (nodes_.empty()) {
    stats.sah_cost = 0.0;
    return;
  }
  SahCost cost(nodes_[0].box(), traversal_cost, intersection_cost);
  double depth_sum = 0;
  struct Item {
    std::uint32_t node;
    int depth;
  };
  std::vector<Item> stack{{0, 0}};
  while (!stack.empty()) {
    const Item item = stack.back();
    stack.pop_back();
    const BvhNode& n = nodes_[item.node];
    ++stats.nodes;
    stats.max_depth = std::max(stats.max_depth, item.depth);
    if (n.leaf()) {
      ++stats.leaves;
      depth_sum += item.depth;
      cost.leaf(n.box(), n.count());
    } else {
      cost.interior(n.box());
      stack.push_back({n.index + 1, item.depth + 1});
      stack.push_back({n.index, item.depth + 1});
    }
  }
  stats.mean_leaf_depth = depth_sum / static_cast<double>(stats.leaves);
  stats.mean_leaf_prims = static_cast<double>(stats.prim_refs) / static_cast<double>(stats.leaves);
  cost.report(stats);
}

}  // namespace splitray

namespace splitray {

Hit Bvh::intersect(const Ray& ray) const {
  if (nodes_.empty()) return Hit{};
  Hit far_end;
  far_end.t = ray.tmax;
  // A select, not a store into the hit: t and prim go back as one register (see walk_from).
  const Hit hit = wide_.intersect(ray, scene_, magnitude_, far_end);
  return hit.found() ? hit : Hit{};
}

Hit Bvh::intersect_counted(const Ray& ray, WideBvhCounts& counts) const {
  Hit hit;
  if (nodes_.empty()) return hit;
  hit.t = ray.tmax;
  hit = wide_.intersect_counted(ray, scene_, magnitude_, hit, counts);
  if (!hit.found()) hit.t = kInfinity;
  return hit;
}

void Bvh::intersect(std::span<const Ray> rays, std::span<Hit> hits) const {
  for (std::size_t i = 0; i < rays.size(); i += WideBvh::kPacketRays) {
    const std::size_t n = std::min<std::size_t>(WideBvh::kPacketRays, rays.size() - i);
    const std::span<const Ray> group = rays.subspan(i, n);
    Hit* out = hits.data() + i;
    if (!nodes_.empty() && (wide_.intersect_packet(group, scene_, magnitude_, out) ||
                            wide_.intersect_group(group, scene_, magnitude_, out))) {
      for (std::size_t r = 0; r < n; ++r)
        if (!out[r].found()) out[r] = Hit{};
      continue;
    }
    for (std::size_t r = 0; r < n; ++r) out[r] = intersect(group[r]);
  }
}

void Bvh::occluded(std::span<const Ray> rays, std::span<std::uint8_t> result) const {
  for (std::size_t i = 0; i < rays.size(); i += WideBvh::kPacketRays) {
    const std::size_t n = std::min<std::size_t>(WideBvh::kPacketRays, rays.size() - i);
    const std::span<const Ray> group = rays.subspan(i, n);
    const std::optional<unsigned> hit =
        nodes_.empty() ? std::nullopt : wide_.occluded_packet(group, scene_, magnitude_);
    if (hit) {
      for (std::size_t r = 0; r < n; ++r) result[i + r] = (*hit >> r) & 1u;
      continue;
    }
    if (!nodes_.empty() && wide_.occluded_group(group, scene_, magnitude_, result.data() + i))
      continue;
    for (std::size_t r = 0; r < n; ++r) result[i + r] = occluded(group[r]) ? 1 : 0;
  }
}

bool Bvh::occluded(const Ray& ray) const {
  return !nodes_.empty() && wide_.occluded(ray, scene_, magnitude_);
}

}  // namespace splitray

// The single-ray calls of the wide layout (wide_bvh.hpp): the walk of wide_bvh_walk.hpp from
// the root.
#include "splitray/accel/bvh/wide_bvh.hpp"
#include "splitray/accel/bvh/wide_bvh_walk.hpp"

namespace splitray {

using wide_bvh::Counting;
using wide_bvh::walk;

Hit WideBvh::intersect(const Ray& ray, const Aabb& scene, float magnitude, Hit so_far) const {
  if (nodes_.empty()) return so_far;
  return walk<false>(nodes_.data(), blocks_.data(), ray, scene, magnitude, so_far);
}

bool WideBvh::occluded(const Ray& ray, const Aabb& scene, float magnitude) const {
  if (nodes_.empty()) return false;
  Hit far_end;
  far_end.t = ray.tmax;
  return walk<true>(nodes_.data(), blocks_.data(), ray, scene, magnitude, far_end);
}

Hit WideBvh::intersect_counted(const Ray& ray, const Aabb& scene, float magnitude,
                               const Hit& so_far, WideBvhCounts& counts) const {
  ++counts.rays;
  if (nodes_.empty()) return so_far;
  // The answer first, so that the counting walk knows which leaves hold it.
  const Hit closest = walk<false>(nodes_.data(), blocks_.data(), ray, scene, magnitude, so_far);
  counts.hits += closest.found() ? 1 : 0;
  return walk<false>(nodes_.data(), blocks_.data(), ray, scene, magnitude, so_far,
                     Counting{counts, closest});
}

}  // namespace splitray

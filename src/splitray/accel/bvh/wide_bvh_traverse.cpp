// The single-ray calls of the wide layout (wide_bvh.hpp): the walk of wide_bvh_walk.hpp from
// the root.
#include "splitray/accel/bvh/wide_bvh.hpp"
#include "splitray/accel/bvh/wide_bvh_walk.hpp"

namespace splitray {

using wide_bvh::Counting;
using wide_bvh::walk;

void WideBvh::intersect(const Ray& ray, const Aabb& scene, float magnitude, Hit& hit) const {
  if (nodes_.empty()) return;
  walk<false>(nodes_.data(), blocks_.data(), ray, scene, magnitude, hit);
}

bool WideBvh::occluded(const Ray& ray, const Aabb& scene, float magnitude) const {
  if (nodes_.empty()) return false;
  Hit hit;
  hit.t = ray.tmax;
  return walk<true>(nodes_.data(), blocks_.data(), ray, scene, magnitude, hit);
}

void WideBvh::intersect_counted(const Ray& ray, const Aabb& scene, float magnitude, Hit& hit,
                                WideBvhCounts& counts) const {
  ++counts.rays;
  if (nodes_.empty()) return;
  Hit closest = hit;  // the answer first, so that the counting walk knows which leaves hold it
  walk<false>(nodes_.data(), blocks_.data(), ray, scene, magnitude, closest);
  counts.hits += closest.found() ? 1 : 0;
  walk<false>(nodes_.data(), blocks_.data(), ray, scene, magnitude, hit, Counting{counts, closest});
}

}  // namespace splitray

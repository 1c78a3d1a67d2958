#pragma once
// Hit points and the offset that starts secondary rays off a surface without hitting it again.
#include <algorithm>
#include <span>

#include "splitray/core/triangle.hpp"

namespace splitray {

// The hit point from the barycentrics: more accurate than org + t * dir far from the origin.
inline Vec3 hit_position(const Triangle& tri, const Hit& hit) {
  return tri.v0 * (1 - hit.u - hit.v) + tri.v1 * hit.u + tri.v2 * hit.v;
}

// How far secondary rays start off a surface, along its geometric normal: 1e-4 of the scene's
// diagonal, and never less than a few float ulps of the largest coordinate (scenes far
// from the origin).
inline float offset_epsilon(const Aabb& bounds) {
  if (bounds.empty()) return 1e-4f;
  const float diagonal = length(bounds.extent());
  const float magnitude = max_component(max(abs(bounds.lo), abs(bounds.hi)));
  return std::max({1e-4f * diagonal, 1e-6f * magnitude, 1e-30f});
}

inline Aabb bounds_of(std::span<const Triangle> triangles) {
  Aabb box;
  for (const Triangle& t : triangles) box.extend(t.bounds());
  return box;
}

}  // namespace splitray

#pragma once
// Perfect-split clipping for the fast builders, which re-clip every straddling triangle at
// every split (their hot spot): clip_triangle_bounds (clip.hpp), faster and with the same
// result (tested on real meshes), so all kd builders see the same clipped bounds. The planes
// of the box that the triangle does not cross leave the polygon unchanged in
// Sutherland-Hodgman clipping, so they are skipped, and a triangle inside the box is
// returned at once.
#include <array>

#include "splitray/core/triangle.hpp"

namespace splitray {

// The polygon triangle ∩ box (Sutherland-Hodgman, planes in clip.cpp's order); returns the
// vertex count (0 when rounding leaves nothing).
inline int clip_triangle_polygon(const Triangle& triangle, const Aabb& bounds, const Aabb& box,
                                 std::array<Vec3, 9>& poly) {
  std::array<Vec3, 9> next;
  poly[0] = triangle.v0, poly[1] = triangle.v1, poly[2] = triangle.v2;
  int count = 3;
  for (int axis = 0; axis < 3 && count > 0; ++axis) {
    for (int side = 0; side < 2 && count > 0; ++side) {
      const float plane = side == 0 ? box.lo[axis] : box.hi[axis];
      // The triangle (hence the polygon, a part of it) is inside this plane: no change.
      if (side == 0 ? bounds.lo[axis] > plane : bounds.hi[axis] < plane) continue;
      const auto inside = [&](const Vec3& p) {
        return side == 0 ? p[axis] >= plane : p[axis] <= plane;
      };
      int out = 0;
      for (int i = 0; i < count; ++i) {
        const Vec3& a = poly[i];
        const Vec3& b = poly[(i + 1) % count];
        const bool in_a = inside(a), in_b = inside(b);
        if (in_a) next[out++] = a;
        if (in_a != in_b && out < 9) {
          const float t = (plane - a[axis]) / (b[axis] - a[axis]);
          Vec3 p = a + (b - a) * t;
          p[axis] = plane;
          next[out++] = p;
        }
      }
      poly = next;
      count = out;
    }
  }
  return count;
}

inline Aabb clip_triangle_bounds_fast(const Triangle& triangle, const Aabb& box) {
  const Aabb bounds = triangle.bounds();
  const Aabb overlap = intersection(bounds, box);
  if (overlap.empty()) return {};
  if (overlap.lo == bounds.lo && overlap.hi == bounds.hi) return bounds;  // inside the box
  std::array<Vec3, 9> poly;
  const int count = clip_triangle_polygon(triangle, bounds, box, poly);
  if (count == 0) return overlap;
  Aabb clipped;
  for (int i = 0; i < count; ++i) clipped.extend(poly[i]);
  clipped = intersection(clipped, box);
  return clipped.empty() ? overlap : clipped;
}

}  // namespace splitray

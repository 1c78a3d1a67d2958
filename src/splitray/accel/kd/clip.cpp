#include "splitray/accel/kd/clip.hpp"

#include <array>

namespace splitray {

Aabb clip_triangle_bounds(const Triangle& triangle, const Aabb& box) {
  const Aabb overlap = intersection(triangle.bounds(), box);
  if (overlap.empty()) return {};
  // A triangle can gain at most one vertex per plane: 3 + 6.
  std::array<Vec3, 9> poly{triangle.v0, triangle.v1, triangle.v2}, next;
  int count = 3;
  for (int axis = 0; axis < 3 && count > 0; ++axis) {
    for (int side = 0; side < 2 && count > 0; ++side) {
      const float plane = side == 0 ? box.lo[axis] : box.hi[axis];
      const auto inside = [&](const Vec3& p) { return side == 0 ? p[axis] >= plane : p[axis] <= plane; };
      int out = 0;
      for (int i = 0; i < count; ++i) {
        const Vec3& a = poly[i];
        const Vec3& b = poly[(i + 1) % count];
        const bool in_a = inside(a), in_b = inside(b);
        if (in_a) next[out++] = a;
        if (in_a != in_b && out < 9) {
          const float t = (plane - a[axis]) / (b[axis] - a[axis]);
          Vec3 p = a + (b - a) * t;
          p[axis] = plane;  // exactly on the plane despite rounding
          next[out++] = p;
        }
      }
      poly = next;
      count = out;
    }
  }
  if (count == 0) return overlap;
  Aabb clipped;
  for (int i = 0; i < count; ++i) clipped.extend(poly[i]);
  clipped = intersection(clipped, box);
  return clipped.empty() ? overlap : clipped;
}

}  // namespace splitray

#include "splitray/accel/kd/clip.hpp"

#include <array>

namespace splitray {

Aabb clip_triangle_bounds(const Triangle& triangle, const Aabb& box) {
  const Aabb bounds = triangle.bounds();
  const Aabb overlap = intersection(bounds, box);
  if (overlap.empty()) return {};
  // A triangle can gain at most one vertex per plane: 3 + 6. Two buffers, swapped per plane.
  std::array<Vec3, 9> buffers[2] = {{triangle.v0, triangle.v1, triangle.v2}, {}};
  int current = 0, count = 3;
  for (int axis = 0; axis < 3 && count > 0; ++axis) {
    for (int side = 0; side < 2 && count > 0; ++side) {
      const float plane = side == 0 ? box.lo[axis] : box.hi[axis];
      // A plane the whole triangle is inside of leaves the polygon as it is: skip it.
      if (side == 0 ? bounds.lo[axis] >= plane : bounds.hi[axis] <= plane) continue;
      const auto inside = [&](const Vec3& p) {
        return side == 0 ? p[axis] >= plane : p[axis] <= plane;
      };
      const std::array<Vec3, 9>& poly = buffers[current];
      std::array<Vec3, 9>& next = buffers[1 - current];
      int out = 0;
      for (int i = 0; i < count; ++i) {
        const Vec3& a = poly[i];
        const Vec3& b = poly[i + 1 == count ? 0 : i + 1];
        const bool in_a = inside(a), in_b = inside(b);
        if (in_a) next[out++] = a;
        if (in_a != in_b && out < 9) {
          const float t = (plane - a[axis]) / (b[axis] - a[axis]);
          Vec3 p = a + (b - a) * t;
          p[axis] = plane;  // exactly on the plane despite rounding
          next[out++] = p;
        }
      }
      current = 1 - current;
      count = out;
    }
  }
  if (count == 0) return overlap;
  Aabb clipped;
  for (int i = 0; i < count; ++i) clipped.extend(buffers[current][i]);
  clipped = intersection(clipped, box);
  return clipped.empty() ? overlap : clipped;
}

}  // namespace splitray

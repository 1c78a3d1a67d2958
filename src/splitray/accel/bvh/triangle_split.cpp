#include "splitray/accel/bvh/triangle_split.hpp"

#include <algorithm>

namespace splitray {

void split_triangle_bounds(const Triangle& tri, const Aabb& box, int axis, float position,
                           Aabb& left, Aabb& right) {
  Aabb l, r;
  for (int i = 0; i < 3; ++i) {
    const Vec3 a = tri.vertex(i), b = tri.vertex(i == 2 ? 0 : i + 1);
    const float pa = a[axis], pb = b[axis];
    if (pa <= position) l.extend(a);
    if (pa >= position) r.extend(a);
    if ((pa < position && pb > position) || (pa > position && pb < position)) {
      const float t = (position - pa) / (pb - pa);
      Vec3 p = a + (b - a) * t;
      p = max(min(p, max(a, b)), min(a, b));  // stay on the edge despite rounding
      p[axis] = position;
      l.extend(p);
      r.extend(p);
    }
  }
  Aabb below = box, above = box;
  below.hi[axis] = std::min(below.hi[axis], position);
  above.lo[axis] = std::max(above.lo[axis], position);
  left = intersection(l, below);
  right = intersection(r, above);
  if (left.empty()) left = {};
  if (right.empty()) right = {};
}

}  // namespace splitray

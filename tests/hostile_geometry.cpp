#include "hostile_geometry.hpp"

#include <cmath>
#include <limits>

#include "splitray/core/random.hpp"

namespace splitray::test {

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// x moved by n ulps (down for negative n).
float ulps(float x, int n) {
  for (; n > 0; --n) x = std::nextafter(x, kInf);
  for (; n < 0; ++n) x = std::nextafter(x, -kInf);
  return x;
}

class Generator {
 public:
  Generator(std::uint64_t seed, int index) : rng_(seed, 0x9e3779b97f4a7c15ULL + 2 * index) {
    scale_ = std::ldexp(1.0f, integer(-12, 16));
    switch (integer(0, 2)) {
      case 0:  // at the origin
        break;
      case 1:  // near it
        for (int a = 0; a < 3; ++a) offset_[a] = scale_ * uniform(-4, 4);
        break;
      default:  // far from it: few bits are left for the geometry's own detail
        for (int a = 0; a < 3; ++a)
          offset_[a] = std::ldexp(scale_, integer(8, 18)) * (integer(0, 1) ? 1.0f : -1.0f);
        break;
    }
    for (int a = 0; a < 3; ++a)
      for (float& p : planes_[a]) p = coord(a, uniform(-1, 1));
    mesh_.name = "hostile mesh " + std::to_string(index) + " (seed " + std::to_string(seed) +
                 ", scale 2^" + std::to_string(std::ilogb(scale_)) + ", offset " +
                 std::to_string(offset_.x) + " " + std::to_string(offset_.y) + " " +
                 std::to_string(offset_.z) + ")";
  }

  HostileMesh build() {
    for (int i = 0; i < 30; ++i) thin(integer(0, 2), coord_any(), integer(0, 8), integer(0, 8));
    for (int i = integer(1, 2); i > 0; --i) wall();
    for (int i = 0; i < 30; ++i) around_plane();
    for (int i = 0; i < 15; ++i) sliver();
    for (int i = 0; i < 10; ++i) degenerate();
    for (int i = 0; i < 15; ++i) duplicate_or_overlap();
    return std::move(mesh_);
  }

 private:
  int integer(int lo, int hi) { return lo + static_cast<int>(rng_.next_u32() % (hi - lo + 1)); }
  float uniform(float lo, float hi) { return lo + (hi - lo) * rng_.next_float(); }
  float coord(int axis, float u) const { return offset_[axis] + scale_ * u; }
  float coord_any() { return uniform(-1, 1); }
  Vec3 point() { return {coord(0, coord_any()), coord(1, coord_any()), coord(2, coord_any())}; }
  float plane(int axis) { return planes_[axis][integer(0, kPlanes - 1)]; }
  void add(const Vec3& a, const Vec3& b, const Vec3& c) { mesh_.tris.push_back({a, b, c}); }

  // A large triangle whose `axis` coordinates are u's position and 0, m1, m2 ulps above it.
  void thin(int axis, float u, int m1, int m2) { thin_at(axis, coord(axis, u), m1, m2); }
  void thin_at(int axis, float c, int m1, int m2) {
    Vec3 v[3] = {point(), point(), point()};
    const int first = integer(0, 2);
    v[first][axis] = c;
    v[(first + 1) % 3][axis] = ulps(c, m1);
    v[(first + 2) % 3][axis] = ulps(c, m2);
    add(v[0], v[1], v[2]);
  }

  // A grid of quads in a plane of `axis` (two triangles each, shared vertices), each vertex
  // 0-3 ulps off the plane: a tessellated wall or floor straddling many cells.
  void wall() {
    const int axis = integer(0, 2), a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    const float c = integer(0, 1) ? plane(axis) : coord(axis, coord_any());
    const int n1 = integer(3, 8), n2 = integer(3, 8);
    const float lo1 = uniform(-1, 0), hi1 = uniform(0, 1), lo2 = uniform(-1, 0),
                hi2 = uniform(0, 1);
    const bool exact = integer(0, 3) == 0;  // some walls lie exactly in their plane
    std::vector<Vec3> grid;
    for (int j = 0; j <= n2; ++j)
      for (int i = 0; i <= n1; ++i) {
        Vec3 p;
        p[axis] = exact ? c : ulps(c, integer(-3, 3));
        p[a1] = coord(a1, lo1 + (hi1 - lo1) * static_cast<float>(i) / static_cast<float>(n1));
        p[a2] = coord(a2, lo2 + (hi2 - lo2) * static_cast<float>(j) / static_cast<float>(n2));
        grid.push_back(p);
      }
    const auto at = [&](int i, int j) { return grid[static_cast<std::size_t>(j * (n1 + 1) + i)]; };
    for (int j = 0; j < n2; ++j)
      for (int i = 0; i < n1; ++i) {
        add(at(i, j), at(i + 1, j), at(i + 1, j + 1));
        add(at(i, j), at(i + 1, j + 1), at(i, j + 1));
      }
  }

  // Triangles in one of the shared planes, a few ulps beside it, or crossing it with a vertex
  // exactly on it: the positions a builder picks as split planes.
  void around_plane() {
    const int axis = integer(0, 2);
    const float c = plane(axis);
    switch (integer(0, 3)) {
      case 0:
        thin_at(axis, c, 0, 0);  // exactly in the plane
        break;
      case 1:
        thin_at(axis, ulps(c, integer(-4, 4)), integer(0, 3), integer(0, 3));
        break;
      case 2: {  // crossing it, one vertex exactly on it
        Vec3 a = point(), b = point(), d = point();
        a[axis] = c;
        b[axis] = ulps(c, integer(1, 6));
        d[axis] = ulps(c, -integer(1, 6));
        add(a, b, d);
        break;
      }
      default: {  // a large triangle crossing the plane
        Vec3 a = point(), b = point(), d = point();
        b[axis] = 2 * c - a[axis];
        add(a, b, d);
        break;
      }
    }
  }

  void sliver() {
    const Vec3 a = point(), far = point();
    if (integer(0, 1)) {  // a needle: two vertices a few ulps apart
      Vec3 b = a;
      for (int k = 0; k < 3; ++k) b[k] = ulps(a[k], integer(-3, 3));
      add(a, b, far);
    } else {  // nearly collinear
      Vec3 mid = (a + far) * 0.5f;
      const int axis = integer(0, 2);
      mid[axis] = ulps(mid[axis], integer(-2, 2));
      add(a, mid, far);
    }
  }

  void degenerate() {
    const Vec3 a = point(), b = point();
    switch (integer(0, 3)) {
      case 0:
        add(a, a, a);
        break;
      case 1:
        add(a, a, b);
        break;
      case 2:
        add(a, (a + b) * 0.5f, b);  // collinear up to rounding
        break;
      default: {  // exactly collinear along an axis
        const int axis = integer(0, 2);
        Vec3 b2 = a, m = a;
        b2[axis] = b[axis];
        m[axis] = 0.5f * (a[axis] + b[axis]);
        add(a, m, b2);
        break;
      }
    }
  }

  // An exact copy (another id: the tie rule decides), the same vertices in another order, or
  // an overlapping triangle in the same plane.
  void duplicate_or_overlap() {
    if (mesh_.tris.empty()) return;
    const Triangle t = mesh_.tris[rng_.next_u32() % mesh_.tris.size()];
    switch (integer(0, 2)) {
      case 0:
        mesh_.tris.push_back(t);
        break;
      case 1:
        add(t.v1, t.v2, t.v0);
        break;
      default: {
        const auto inside = [&](float a, float b) {
          return t.v0 + (t.v1 - t.v0) * a + (t.v2 - t.v0) * b;
        };
        add(inside(0.5f, 0.0f), inside(-0.3f, 0.8f), inside(0.6f, 0.6f));
        break;
      }
    }
  }

  static constexpr int kPlanes = 4;
  Pcg32 rng_;
  float scale_ = 1;
  Vec3 offset_{0.0f};
  float planes_[3][kPlanes] = {};
  HostileMesh mesh_;
};

}  // namespace

HostileMesh hostile_mesh(std::uint64_t seed, int index) { return Generator(seed, index).build(); }

}  // namespace splitray::test

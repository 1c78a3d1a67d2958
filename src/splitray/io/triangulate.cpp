#include "splitray/io/triangulate.hpp"

#include <cmath>

namespace splitray {
namespace {

struct P2 {
  double u, v;
};

// Twice the signed area of triangle (a, b, c).
double orient(const P2& a, const P2& b, const P2& c) {
  return (b.u - a.u) * (c.v - a.v) - (b.v - a.v) * (c.u - a.u);
}

}  // namespace

std::uint64_t triangulate_polygon(std::span<const Vec3> corners,
                                  std::vector<std::array<std::uint32_t, 3>>& out) {
  const std::size_t n = corners.size();
  if (n < 3) return 0;
  if (n == 3) {
    out.push_back({0, 1, 2});
    return 1;
  }
  std::uint64_t work = n;
  // Newell's normal picks the projection plane: drop its largest component.
  double nx = 0, ny = 0, nz = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3& a = corners[i];
    const Vec3& b = corners[(i + 1) % n];
    nx += (double(a.y) - b.y) * (double(a.z) + b.z);
    ny += (double(a.z) - b.z) * (double(a.x) + b.x);
    nz += (double(a.x) - b.x) * (double(a.y) + b.y);
  }
  const int drop = std::fabs(nx) >= std::fabs(ny) ? (std::fabs(nx) >= std::fabs(nz) ? 0 : 2)
                                                  : (std::fabs(ny) >= std::fabs(nz) ? 1 : 2);
  const int iu = drop == 0 ? 1 : 0, iv = drop == 2 ? 1 : 2;
  std::vector<P2> p(n);
  double area = 0;
  for (std::size_t i = 0; i < n; ++i) p[i] = {corners[i][iu], corners[i][iv]};
  for (std::size_t i = 0; i < n; ++i) {
    const P2& a = p[i];
    const P2& b = p[(i + 1) % n];
    area += a.u * b.v - b.u * a.v;
  }
  const double sign = area < 0 ? -1.0 : 1.0;  // orientation of the polygon in the plane

  std::vector<std::uint32_t> prev(n), next(n);
  for (std::size_t i = 0; i < n; ++i) {
    prev[i] = static_cast<std::uint32_t>((i + n - 1) % n);
    next[i] = static_cast<std::uint32_t>((i + 1) % n);
  }
  auto is_ear = [&](std::uint32_t b) {
    const std::uint32_t a = prev[b], c = next[b];
    if (sign * orient(p[a], p[b], p[c]) <= 0) return false;  // reflex or flat corner
    // No other corner inside or on the candidate triangle (corners at a, b or c themselves
    // do not count: repeated vertices are common).
    for (std::uint32_t k = next[c]; k != a; k = next[k]) {
      ++work;
      const P2& q = p[k];
      if ((q.u == p[a].u && q.v == p[a].v) || (q.u == p[b].u && q.v == p[b].v) ||
          (q.u == p[c].u && q.v == p[c].v))
        continue;
      if (sign * orient(p[a], p[b], q) >= 0 && sign * orient(p[b], p[c], q) >= 0 &&
          sign * orient(p[c], p[a], q) >= 0)
        return false;
    }
    return true;
  };

  std::size_t remaining = n;
  std::uint32_t b = 1;         // ears from corner 1 on: a convex polygon becomes the fan from 0
  std::size_t since_clip = 0;  // candidates tried since the last clip
  while (remaining > 3) {
    if (is_ear(b) || since_clip >= remaining) {  // no proper ear left: clip here regardless
      const std::uint32_t a = prev[b], c = next[b];
      out.push_back({a, b, c});
      next[a] = c;
      prev[c] = a;
      --remaining;
      since_clip = 0;
      b = c;  // the new corner c keeps the fan order for convex polygons
    } else {
      b = next[b];
      ++since_clip;
    }
  }
  out.push_back({prev[b], b, next[b]});
  return work;
}

}  // namespace splitray

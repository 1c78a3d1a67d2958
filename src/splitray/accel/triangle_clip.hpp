#pragma once
// Conservative clipping of a triangle to a box or at a plane: the perfect splits of every kd
// builder, the kd top of a BVH and the SBVH's spatial splits decide from these bounds which
// cells and nodes hold a triangle, so a bound that misses a sliver of it loses hits there.
//
// The guarantee: the box returned contains the exact (real-number) intersection of the
// triangle with the box or half-space. Float clipping with crossings rounded to nearest gave
// no such guarantee: for a triangle a few ulps thick in y, a crossing whose true y lies a
// fraction of an ulp below the top rounds onto it, the clipped box becomes flat, the planar
// rule sends the triangle above a split at that y only, and the cell below, where the triangle
// really lies, loses it (issue #19, a tessellated wall of the Sponza atrium). Why it holds:
// - The polygon triangle ∩ box is clipped plane by plane (Sutherland-Hodgman) in double, and
//   every vertex carries a bound on the error of each coordinate. Its vertices are of three
//   kinds, and each is computed from the float input itself, never from earlier rounded
//   vertices, so errors do not pile up: the triangle's vertices (exact); crossings of a
//   triangle edge with a plane, from the edge's two float endpoints (a few double roundings:
//   2^-50 of the coordinates); points where the triangle's plane meets a line on which two of
//   the box's planes cross, from the plane equation, with a bound that grows as the line
//   turns parallel to the triangle (then the segment's own extent bounds the point).
// - A vertex within its error of a plane counts as inside, so no vertex of the true polygon is
//   ever dropped; the computed polygon can only be larger.
// - The bounds of the vertices, each widened by its errors, are rounded outward to float and
//   cut to the box and to the triangle's own bounds (both exact).
// So a clipped box is flat on an axis only when the triangle is exactly planar in that axis
// or touches the box only in a face, never because of rounding, and the builders' planar rule
// (kd/kd_sah.hpp) sends such a box to a side that really holds its part of the triangle.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>

#include "splitray/core/triangle.hpp"

namespace splitray {

namespace clip_detail {

struct ClipVertex {
  double p[3];
  double err[3];       // |exact - p[j]| <= err[j]; 0 on a plane the vertex was made on
  std::uint8_t edges;  // bit e: lies on the triangle's edge e (vertex e to vertex e + 1)
};

// A convex polygon gains at most one vertex per plane; the vertices counted inside by their
// error may make the computed one slightly non-convex, so leave room.
inline constexpr int kCapacity = 32;
using Polygon = std::array<ClipVertex, kCapacity>;

// The triangle in double, and its plane (n . x = n . v0) with bounds on the normal's errors.
struct ClipTriangle {
  double v[3][3];
  double n[3], n_err[3];

  explicit ClipTriangle(const Triangle& t) {
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) v[i][j] = t.vertex(i)[j];
    double e1[3], e2[3];
    for (int j = 0; j < 3; ++j) e1[j] = v[1][j] - v[0][j], e2[j] = v[2][j] - v[0][j];
    for (int j = 0; j < 3; ++j) {
      const int a = (j + 1) % 3, b = (j + 2) % 3;
      const double p1 = e1[a] * e2[b], p2 = e1[b] * e2[a];
      n[j] = p1 - p2;
      n_err[j] = (std::fabs(p1) + std::fabs(p2)) * 0x1p-50;
    }
  }

  ClipVertex vertex(int i) const {
    ClipVertex c{{v[i][0], v[i][1], v[i][2]}, {0, 0, 0}, 0};
    c.edges = static_cast<std::uint8_t>((1u << i) | (1u << ((i + 2) % 3)));
    return c;
  }
};

// The largest float <= x and the smallest float >= x.
inline float float_below(double x) {
  const float f = static_cast<float>(x);
  return static_cast<double>(f) <= x ? f
                                     : std::nextafter(f, -std::numeric_limits<float>::infinity());
}
inline float float_above(double x) {
  const float f = static_cast<float>(x);
  return static_cast<double>(f) >= x ? f
                                     : std::nextafter(f, std::numeric_limits<float>::infinity());
}

// Where the triangle's edge e meets `plane` on `axis`, from the edge's float endpoints.
inline ClipVertex edge_crossing(const ClipTriangle& tri, int e, int axis, double plane) {
  const double* a = tri.v[e];
  const double* b = tri.v[(e + 1) % 3];
  const double t = (plane - a[axis]) / (b[axis] - a[axis]);
  ClipVertex c;
  for (int j = 0; j < 3; ++j) {
    c.p[j] = std::clamp(a[j] + (b[j] - a[j]) * t, std::min(a[j], b[j]), std::max(a[j], b[j]));
    c.err[j] = a[j] == b[j] ? 0 : (std::fabs(a[j]) + std::fabs(b[j])) * 0x1p-50;
  }
  c.p[axis] = plane;
  c.err[axis] = 0;
  c.edges = static_cast<std::uint8_t>(1u << e);
  return c;
}

// The bounds on the segment a-b's coordinate j: where any point of it can be.
inline void segment_extent(const ClipVertex& a, const ClipVertex& b, int j, double& lo,
                           double& hi) {
  lo = std::min(a.p[j] - a.err[j], b.p[j] - b.err[j]);
  hi = std::max(a.p[j] + a.err[j], b.p[j] + b.err[j]);
}

// Where the segment a-b, which lies in the plane x[m] = a.p[m] (exactly: both are on it),
// meets `plane` on `axis`: the point of the triangle's plane on the line where the two planes
// cross. Its third coordinate comes from the plane equation; where that is ill-conditioned
// (the line nearly parallel to the triangle), the segment's extent bounds it.
inline ClipVertex line_crossing(const ClipTriangle& tri, const ClipVertex& a, const ClipVertex& b,
                                int m, int axis, double plane) {
  const int j = 3 - m - axis;
  ClipVertex c;
  c.p[m] = a.p[m];
  c.p[axis] = plane;
  c.err[m] = c.err[axis] = 0;
  c.edges = 0;
  double lo, hi;
  segment_extent(a, b, j, lo, hi);
  const double dm = c.p[m] - tri.v[0][m], dk = plane - tri.v[0][axis];
  const double num = tri.n[m] * dm + tri.n[axis] * dk;
  const double num_err = tri.n_err[m] * std::fabs(dm) + tri.n_err[axis] * std::fabs(dk) +
                         (std::fabs(tri.n[m] * dm) + std::fabs(tri.n[axis] * dk)) * 0x1p-51;
  const double nj = std::fabs(tri.n[j]) - tri.n_err[j];  // the least |n[j]| can be
  if (nj > 0) {
    const double q = num / tri.n[j];
    const double x = tri.v[0][j] - q;
    const double err =
        (num_err + std::fabs(q) * tri.n_err[j]) / nj + (std::fabs(q) + std::fabs(x)) * 0x1p-51;
    if (x + err < lo || x - err > hi) {
      // Beyond the segment: the line meets the plane past the endpoint the step kept only for
      // its error, so the true crossing lies on a neighbouring segment, between vertices that
      // are kept; this one may stand at that endpoint.
      const ClipVertex& near = x + err < lo ? (a.p[j] < b.p[j] ? a : b) : (a.p[j] > b.p[j] ? a : b);
      lo = near.p[j] - near.err[j];
      hi = near.p[j] + near.err[j];
    } else {
      lo = std::max(lo, x - err);
      hi = std::min(hi, x + err);
    }
  }
  c.p[j] = 0.5 * (lo + hi);
  c.err[j] = 0.5 * (hi - lo) + std::fabs(c.p[j]) * 0x1p-52;
  return c;
}

// Any other segment (the polygon's structure lost to degenerate input): interpolated, with
// the endpoints' errors plus the slide along the segment that their error across the plane
// causes, never more than the segment's extent.
inline ClipVertex segment_crossing(const ClipVertex& a, const ClipVertex& b, int axis,
                                   double plane) {
  const double dk = b.p[axis] - a.p[axis];
  const double t = dk != 0 ? std::clamp((plane - a.p[axis]) / dk, 0.0, 1.0) : 0.5;
  const double across = std::max(a.err[axis], b.err[axis]);
  const double slide = across > 0 ? 2 * across / std::fabs(dk) : 0;  // inf when dk == 0
  ClipVertex c;
  for (int j = 0; j < 3; ++j) {
    const double d = b.p[j] - a.p[j];
    c.p[j] = a.p[j] + d * t;
    const double moved = d != 0 && slide > 0 ? std::min(std::fabs(d) * slide, std::fabs(d)) : 0;
    c.err[j] =
        std::max(a.err[j], b.err[j]) + moved + (std::fabs(a.p[j]) + std::fabs(b.p[j])) * 0x1p-50;
  }
  c.p[axis] = plane;
  c.err[axis] = 0;
  c.edges = 0;
  return c;
}

inline ClipVertex crossing(const ClipTriangle& tri, const ClipVertex& a, const ClipVertex& b,
                           int axis, double plane) {
  if (const unsigned shared = a.edges & b.edges) {
    const int e = std::countr_zero(shared);
    if (tri.v[e][axis] != tri.v[(e + 1) % 3][axis]) return edge_crossing(tri, e, axis, plane);
  }
  for (int m = 0; m < 3; ++m)
    if (m != axis && a.err[m] == 0 && b.err[m] == 0 && a.p[m] == b.p[m])
      return line_crossing(tri, a, b, m, axis, plane);
  return segment_crossing(a, b, axis, plane);
}

// One Sutherland-Hodgman step: the part of `in` on the side of `plane` (on `axis`) that is kept
// (above it if keep_above, else below it). Returns the vertex count, or -1 when it would not
// fit (never seen; the caller then falls back to the unclipped bounds).
inline int clip_step(const ClipTriangle& tri, const ClipVertex* in, int n, int axis, double plane,
                     bool keep_above, ClipVertex* out) {
  const auto inside = [&](const ClipVertex& v) {
    return keep_above ? v.p[axis] + v.err[axis] >= plane : v.p[axis] - v.err[axis] <= plane;
  };
  int count = 0;
  bool in_a = inside(in[0]);
  for (int i = 0; i < n; ++i) {
    const ClipVertex& a = in[i];
    const ClipVertex& b = in[i + 1 == n ? 0 : i + 1];
    const bool in_b = inside(b);
    if (count + 2 > kCapacity) return -1;
    if (in_a) out[count++] = a;
    if (in_a != in_b) out[count++] = crossing(tri, a, b, axis, plane);
    in_a = in_b;
  }
  return count;
}

// The polygon triangle ∩ box into `poly`; returns its vertex count (0: nothing left, -1: too
// many vertices). Planes the triangle lies inside of are skipped: they change nothing.
inline int clip_to_box(const ClipTriangle& tri, const Aabb& tri_bounds, const Aabb& box,
                       Polygon& poly) {
  Polygon other;
  ClipVertex* cur = poly.data();
  ClipVertex* next = other.data();
  for (int i = 0; i < 3; ++i) cur[i] = tri.vertex(i);
  int count = 3;
  for (int axis = 0; axis < 3 && count > 0; ++axis) {
    if (tri_bounds.lo[axis] < box.lo[axis]) {
      count = clip_step(tri, cur, count, axis, box.lo[axis], true, next);
      std::swap(cur, next);
    }
    if (count > 0 && tri_bounds.hi[axis] > box.hi[axis]) {
      count = clip_step(tri, cur, count, axis, box.hi[axis], false, next);
      std::swap(cur, next);
    }
  }
  if (count > 0 && cur != poly.data()) std::copy(cur, cur + count, poly.data());
  return count;
}

// The float box holding every vertex with its errors, cut to `limit`; empty when nothing is
// left of it inside `limit`.
inline Aabb widened_bounds(const ClipVertex* v, int n, const Aabb& limit) {
  double lo[3], hi[3];
  for (int j = 0; j < 3; ++j) {
    lo[j] = v[0].p[j] - v[0].err[j];
    hi[j] = v[0].p[j] + v[0].err[j];
  }
  for (int i = 1; i < n; ++i)
    for (int j = 0; j < 3; ++j) {
      lo[j] = std::min(lo[j], v[i].p[j] - v[i].err[j]);
      hi[j] = std::max(hi[j], v[i].p[j] + v[i].err[j]);
    }
  Aabb b;
  for (int j = 0; j < 3; ++j) {
    b.lo[j] = std::max(float_below(lo[j]), limit.lo[j]);
    b.hi[j] = std::min(float_above(hi[j]), limit.hi[j]);
  }
  return b;
}

}  // namespace clip_detail

// Bounds of triangle ∩ box, inside `box`; empty when the triangle's bounds miss the box.
// When clipping leaves nothing although the bounds overlap the box (the triangle passes by a
// corner of the box), returns that overlap: conservative, and what every builder expects.
inline Aabb clip_triangle_bounds(const Triangle& triangle, const Aabb& box) {
  using namespace clip_detail;
  const Aabb bounds = triangle.bounds();
  const Aabb overlap = intersection(bounds, box);
  if (overlap.empty()) return {};
  if (overlap.lo == bounds.lo && overlap.hi == bounds.hi) return bounds;  // inside the box
  const ClipTriangle tri(triangle);
  Polygon poly;
  const int count = clip_to_box(tri, bounds, box, poly);
  if (count <= 0) return overlap;
  const Aabb clipped = widened_bounds(poly.data(), count, overlap);
  return clipped.empty() ? overlap : clipped;
}

// Both children's clipped bounds of a triangle that straddles the plane `position` on `axis`
// of `cell` (the kd builders' straddlers): the polygon triangle ∩ cell is clipped once, then
// at the plane for each side. A side left empty falls back to the triangle's bounds ∩ that
// child cell, as clip_triangle_bounds does.
inline void clip_triangle_split(const Triangle& triangle, const Aabb& cell, int axis,
                                float position, Aabb& below, Aabb& above) {
  using namespace clip_detail;
  const Aabb bounds = triangle.bounds();
  Aabb below_cell = cell, above_cell = cell;
  below_cell.hi[axis] = position;
  above_cell.lo[axis] = position;
  const Aabb below_limit = intersection(bounds, below_cell);
  const Aabb above_limit = intersection(bounds, above_cell);
  below = below_limit;
  above = above_limit;
  const ClipTriangle tri(triangle);
  Polygon poly, side;
  const int count = clip_to_box(tri, bounds, cell, poly);
  if (count <= 0) return;
  const int n_below = clip_step(tri, poly.data(), count, axis, position, false, side.data());
  if (n_below > 0) {
    const Aabb b = widened_bounds(side.data(), n_below, below_limit);
    if (!b.empty()) below = b;
  }
  const int n_above = clip_step(tri, poly.data(), count, axis, position, true, side.data());
  if (n_above > 0) {
    const Aabb a = widened_bounds(side.data(), n_above, above_limit);
    if (!a.empty()) above = a;
  }
}

// The SBVH's split of a reference at a plane: the bounds of the triangle's part on each side
// of `position` on `axis` (left: <=, right: >=), cut to the reference's box `box`. A side the
// triangle does not reach inside `box` comes back empty.
inline void split_triangle_bounds(const Triangle& triangle, const Aabb& box, int axis,
                                  float position, Aabb& left, Aabb& right) {
  using namespace clip_detail;
  const Aabb bounds = triangle.bounds();
  Aabb left_limit = box, right_limit = box;
  left_limit.hi[axis] = std::min(left_limit.hi[axis], position);
  right_limit.lo[axis] = std::max(right_limit.lo[axis], position);
  left_limit = intersection(left_limit, bounds);
  right_limit = intersection(right_limit, bounds);
  const ClipTriangle tri(triangle);
  Polygon poly, side;
  for (int i = 0; i < 3; ++i) poly[i] = tri.vertex(i);
  const auto side_bounds = [&](bool keep_above, const Aabb& limit) {
    if (limit.empty()) return Aabb{};
    const int n = clip_step(tri, poly.data(), 3, axis, position, keep_above, side.data());
    if (n < 0) return limit;
    const Aabb b = n == 0 ? Aabb{} : widened_bounds(side.data(), n, limit);
    return b.empty() ? Aabb{} : b;
  };
  left = side_bounds(false, left_limit);
  right = side_bounds(true, right_limit);
}

}  // namespace splitray

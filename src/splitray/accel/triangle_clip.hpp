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
  float err[3];        // |exact - p[j]| <= err[j]; 0 where p[j] is exact (a triangle vertex,
                       // a plane it was made on); rounded up: a bound needs no more precision
  std::uint8_t edges;  // bit e: lies on the triangle's edge e (vertex e to vertex e + 1)

  float e(int j) const { return err[j]; }
};

// A convex polygon gains at most one vertex per plane; the vertices counted inside by their
// error may make the computed one slightly non-convex, so leave room.
inline constexpr int kCapacity = 32;
using Polygon = std::array<ClipVertex, kCapacity>;

// The float after f toward +inf (f finite), without a library call: the builders' hot path.
inline float float_up(float f) {
  const auto bits = std::bit_cast<std::uint32_t>(f);
  if (bits == 0x80000000u) return std::bit_cast<float>(1u);  // -0: the least positive float
  return std::bit_cast<float>((bits >> 31) ? bits - 1 : bits + 1);
}
inline float float_down(float f) { return -float_up(-f); }

// The largest float <= x and the smallest float >= x.
inline float float_below(double x) {
  const float f = static_cast<float>(x);
  return static_cast<double>(f) <= x ? f : float_down(f);
}
inline float float_above(double x) {
  const float f = static_cast<float>(x);
  return static_cast<double>(f) >= x ? f : float_up(f);
}

// The triangle in double, and its plane (n . x = n . v0) with bounds on the normal's errors,
// made when a crossing first needs it (most clips never do).
struct ClipTriangle {
  double v[3][3];
  float edge_err[3][3];  // the error of coordinate j of a crossing on edge e: 0 where the
                         // edge keeps it, else a bound on the rounding of its computation
  mutable double n[3], n_err[3];
  mutable bool has_plane = false;

  explicit ClipTriangle(const Triangle& t) {
    const Vec3 corners[3] = {t.v0, t.v1, t.v2};
    double scale = 0;
    for (int i = 0; i < 3; ++i) {
      v[i][0] = corners[i].x, v[i][1] = corners[i].y, v[i][2] = corners[i].z;
      scale = std::max({scale, std::fabs(v[i][0]), std::fabs(v[i][1]), std::fabs(v[i][2])});
    }
    // A few double roundings of values at most `scale` (t, then a + (b - a) t): 2^-49 of it
    // bounds them with a wide margin.
    const float rounding = float_above(scale * 0x1p-49);
    for (int e = 0; e < 3; ++e) {
      const double* a = v[e];
      const double* b = v[e == 2 ? 0 : e + 1];
      for (int j = 0; j < 3; ++j) edge_err[e][j] = a[j] == b[j] ? 0 : rounding;
    }
  }

  void make_plane() const {
    if (has_plane) return;
    double e1[3], e2[3];
    for (int j = 0; j < 3; ++j) e1[j] = v[1][j] - v[0][j], e2[j] = v[2][j] - v[0][j];
    for (int j = 0; j < 3; ++j) {
      const int a = (j + 1) % 3, b = (j + 2) % 3;
      const double p1 = e1[a] * e2[b], p2 = e1[b] * e2[a];
      n[j] = p1 - p2;
      n_err[j] = (std::fabs(p1) + std::fabs(p2)) * 0x1p-50;
    }
    has_plane = true;
  }

  ClipVertex vertex(int i) const {
    ClipVertex c{{v[i][0], v[i][1], v[i][2]}, {0, 0, 0}, 0};
    c.edges = static_cast<std::uint8_t>((1u << i) | (1u << ((i + 2) % 3)));
    return c;
  }
};

// Where the triangle's edge e meets `plane` on `axis`, from the edge's float endpoints (the
// common case: kept short and inline).
inline ClipVertex edge_crossing(const ClipTriangle& tri, int e, int axis, double plane) {
  const double* a = tri.v[e];
  const double* b = tri.v[e == 2 ? 0 : e + 1];
  const double t = std::clamp((plane - a[axis]) / (b[axis] - a[axis]), 0.0, 1.0);
  ClipVertex c;
  for (int j = 0; j < 3; ++j) c.p[j] = a[j] + (b[j] - a[j]) * t;
  c.p[axis] = plane;
  for (int j = 0; j < 3; ++j) c.err[j] = tri.edge_err[e][j];
  c.err[axis] = 0;
  c.edges = static_cast<std::uint8_t>(1u << e);
  return c;
}

// The bounds on the segment a-b's coordinate j: where any point of it can be.
inline void segment_extent(const ClipVertex& a, const ClipVertex& b, int j, double& lo,
                           double& hi) {
  lo = std::min(a.p[j] - a.e(j), b.p[j] - b.e(j));
  hi = std::max(a.p[j] + a.e(j), b.p[j] + b.e(j));
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
  tri.make_plane();
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
      lo = near.p[j] - near.e(j);
      hi = near.p[j] + near.e(j);
    } else {
      lo = std::max(lo, x - err);
      hi = std::min(hi, x + err);
    }
  }
  c.p[j] = 0.5 * (lo + hi);
  c.err[j] = float_above(0.5 * (hi - lo) + std::fabs(c.p[j]) * 0x1p-52);
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
    const double along = std::max(a.err[j], b.err[j]);
    if (d == 0) {  // kept (exactly, where both ends are: a plane the segment lies in)
      c.p[j] = a.p[j];
      c.err[j] = static_cast<float>(along);
      continue;
    }
    c.p[j] = a.p[j] + d * t;
    const double moved = slide > 0 ? std::min(std::fabs(d) * slide, std::fabs(d)) : 0;
    c.err[j] = float_above(along + moved + (std::fabs(a.p[j]) + std::fabs(b.p[j])) * 0x1p-50);
  }
  c.p[axis] = plane;
  c.err[axis] = 0;
  c.edges = 0;
  return c;
}

// A segment that is not part of a triangle edge: in a plane of the box, or (degenerate input)
// neither.
[[gnu::noinline]] inline ClipVertex other_crossing(const ClipTriangle& tri, const ClipVertex& a,
                                                   const ClipVertex& b, int axis, double plane) {
  for (int m = 0; m < 3; ++m)
    if (m != axis && a.err[m] == 0 && b.err[m] == 0 && a.p[m] == b.p[m])
      return line_crossing(tri, a, b, m, axis, plane);
  return segment_crossing(a, b, axis, plane);
}

inline ClipVertex crossing(const ClipTriangle& tri, const ClipVertex& a, const ClipVertex& b,
                           int axis, double plane) {
  if (const unsigned shared = a.edges & b.edges) {
    const int e = std::countr_zero(shared);
    if (tri.v[e][axis] != tri.v[e == 2 ? 0 : e + 1][axis])
      return edge_crossing(tri, e, axis, plane);
  }
  return other_crossing(tri, a, b, axis, plane);
}

// One Sutherland-Hodgman step: the part of `in` on the side of `plane` (on `axis`) that is kept
// (above it if keep_above, else below it). Returns the vertex count, or -1 when it would not
// fit (never seen; the caller then falls back to the unclipped bounds).
inline int clip_step(const ClipTriangle& tri, const ClipVertex* in, int n, int axis, double plane,
                     bool keep_above, ClipVertex* out) {
  const auto inside = [&](const ClipVertex& v) {
    return keep_above ? v.p[axis] + v.e(axis) >= plane : v.p[axis] - v.e(axis) <= plane;
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

// The float box of [lo, hi] (rounded outward), cut to `limit`; empty when nothing of it is
// inside `limit`. Written axis by axis: the builders' hot path.
inline Aabb rounded_bounds(const double lo[3], const double hi[3], const Aabb& limit) {
  const Aabb r{{std::max(float_below(lo[0]), limit.lo.x), std::max(float_below(lo[1]), limit.lo.y),
                std::max(float_below(lo[2]), limit.lo.z)},
               {std::min(float_above(hi[0]), limit.hi.x), std::min(float_above(hi[1]), limit.hi.y),
                std::min(float_above(hi[2]), limit.hi.z)}};
  return r.empty() ? Aabb{} : r;
}

// The float box holding every vertex with its errors, cut to `limit`; empty when nothing is
// left of it inside `limit`.
inline Aabb widened_bounds(const ClipVertex* v, int n, const Aabb& limit) {
  double lo[3], hi[3];
  for (int j = 0; j < 3; ++j) {
    lo[j] = v[0].p[j] - v[0].e(j);
    hi[j] = v[0].p[j] + v[0].e(j);
  }
  for (int i = 1; i < n; ++i)
    for (int j = 0; j < 3; ++j) {
      lo[j] = std::min(lo[j], v[i].p[j] - v[i].e(j));
      hi[j] = std::max(hi[j], v[i].p[j] + v[i].e(j));
    }
  return rounded_bounds(lo, hi, limit);
}

// Both sides' bounds of the polygon `poly` cut at `position` on `axis` in one pass (a crossing
// made once serves both sides), each cut to its limit: the vertices clip_step would keep on
// each side, so the same bounds as clipping twice; empty for a side the polygon misses.
inline void split_polygon(const ClipTriangle& tri, const ClipVertex* poly, int n, int axis,
                          double position, const Aabb& below_limit, const Aabb& above_limit,
                          Aabb& below, Aabb& above) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  double lo[2][3] = {{kInf, kInf, kInf}, {kInf, kInf, kInf}};
  double hi[2][3] = {{-kInf, -kInf, -kInf}, {-kInf, -kInf, -kInf}};
  const auto extend = [&](int side, const ClipVertex& v) {
    for (int j = 0; j < 3; ++j) {
      lo[side][j] = std::min(lo[side][j], v.p[j] - v.e(j));
      hi[side][j] = std::max(hi[side][j], v.p[j] + v.e(j));
    }
  };
  const auto on_below = [&](const ClipVertex& v) { return v.p[axis] - v.e(axis) <= position; };
  const auto on_above = [&](const ClipVertex& v) { return v.p[axis] + v.e(axis) >= position; };
  bool below_a = on_below(poly[0]), above_a = on_above(poly[0]);
  for (int i = 0; i < n; ++i) {
    const ClipVertex& a = poly[i];
    const ClipVertex& b = poly[i + 1 == n ? 0 : i + 1];
    const bool below_b = on_below(b), above_b = on_above(b);
    if (below_a) extend(0, a);
    if (above_a) extend(1, a);
    if (below_a != below_b || above_a != above_b) {
      const ClipVertex c = crossing(tri, a, b, axis, position);
      if (below_a != below_b) extend(0, c);
      if (above_a != above_b) extend(1, c);
    }
    below_a = below_b;
    above_a = above_b;
  }
  below = lo[0][0] <= hi[0][0] ? rounded_bounds(lo[0], hi[0], below_limit) : Aabb{};
  above = lo[1][0] <= hi[1][0] ? rounded_bounds(lo[1], hi[1], above_limit) : Aabb{};
}

// Both sides' bounds of the triangle's part in the slab [slab_lo, slab_hi] on `axis` cut at
// `position` inside it, each cut to its limit: its vertices on each side and its edges'
// crossings with the three planes (slab_lo counts below, `position` both sides, slab_hi
// above), each crossing computed from the edge's float ends, so no polygon to carry and no
// plane equation. With an unbounded slab: the whole triangle cut at a plane.
inline void split_in_slab(const Triangle& triangle, int axis, double slab_lo, float position,
                          double slab_hi, const Aabb& below_limit, const Aabb& above_limit,
                          Aabb& below, Aabb& above) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  double lo[2][3] = {{kInf, kInf, kInf}, {kInf, kInf, kInf}};
  double hi[2][3] = {{-kInf, -kInf, -kInf}, {-kInf, -kInf, -kInf}};
  double v[3][3];
  double scale = 0;
  const Vec3 corners[3] = {triangle.v0, triangle.v1, triangle.v2};
  for (int i = 0; i < 3; ++i) {
    v[i][0] = corners[i].x, v[i][1] = corners[i].y, v[i][2] = corners[i].z;
    scale = std::max({scale, std::fabs(v[i][0]), std::fabs(v[i][1]), std::fabs(v[i][2])});
  }
  const double rounding = scale * 0x1p-49;  // as ClipTriangle::rounding
  const double plane[3] = {slab_lo, position, slab_hi};
  const auto extend = [&](int side, int j, double c, double err) {
    lo[side][j] = std::min(lo[side][j], c - err);
    hi[side][j] = std::max(hi[side][j], c + err);
  };
  for (int i = 0; i < 3; ++i) {
    const double* a = v[i];
    const double* b = v[i == 2 ? 0 : i + 1];
    const bool in_below = a[axis] >= slab_lo && a[axis] <= position;
    const bool in_above = a[axis] >= position && a[axis] <= slab_hi;
    for (int j = 0; j < 3; ++j) {
      if (in_below) extend(0, j, a[j], 0);
      if (in_above) extend(1, j, a[j], 0);
    }
    for (int k = 0; k < 3; ++k) {
      const double q = plane[k];
      if (!((a[axis] < q && b[axis] > q) || (a[axis] > q && b[axis] < q))) continue;
      const double t = (q - a[axis]) / (b[axis] - a[axis]);
      for (int j = 0; j < 3; ++j) {
        double c = q, err = 0;
        if (j != axis && a[j] != b[j]) {
          c = std::clamp(a[j] + (b[j] - a[j]) * t, std::min(a[j], b[j]), std::max(a[j], b[j]));
          err = rounding;
        } else if (j != axis) {
          c = a[j];
        }
        if (k <= 1) extend(0, j, c, err);
        if (k >= 1) extend(1, j, c, err);
      }
    }
  }
  below = lo[0][0] <= hi[0][0] ? rounded_bounds(lo[0], hi[0], below_limit) : Aabb{};
  above = lo[1][0] <= hi[1][0] ? rounded_bounds(lo[1], hi[1], above_limit) : Aabb{};
}

}  // namespace clip_detail

// How tight the children's boxes of a straddler are: `exact`, the bounds of the triangle's
// part in each child cell; `slab`, the bounds of its part in the child's slab on the split
// axis, cut to the child cell (as tight where the triangle leaves the cell only across the
// split axis' planes, looser elsewhere, and much cheaper: no polygon). Both are conservative.
enum class ClipTightness { exact, slab };

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
// of `cell` (the kd builders' straddlers). `part` is a box known to hold triangle ∩ cell (its
// clipped bounds in the cell; the triangle's bounds when there are none): the children's
// boxes never leave it. `exact`: the polygon triangle ∩ cell is clipped once, then split at
// the plane; `slab`: see ClipTightness. A side left empty falls back to `part` ∩ that child
// cell, as clip_triangle_bounds does.
inline void clip_triangle_split(const Triangle& triangle, const Aabb& cell, const Aabb& part,
                                int axis, float position, Aabb& below, Aabb& above,
                                ClipTightness tightness) {
  using namespace clip_detail;
  const Aabb bounds = triangle.bounds();
  Aabb below_cell = cell, above_cell = cell;
  below_cell.hi[axis] = position;
  above_cell.lo[axis] = position;
  const Aabb known = intersection(bounds, part);
  const Aabb below_limit = intersection(known, below_cell);
  const Aabb above_limit = intersection(known, above_cell);
  below = below_limit;
  above = above_limit;
  Aabb b, a;
  if (bounds.lo.x >= cell.lo.x && bounds.lo.y >= cell.lo.y && bounds.lo.z >= cell.lo.z &&
      bounds.hi.x <= cell.hi.x && bounds.hi.y <= cell.hi.y && bounds.hi.z <= cell.hi.z) {
    constexpr double kInf = std::numeric_limits<double>::infinity();
    split_in_slab(triangle, axis, -kInf, position, kInf, below_limit, above_limit, b, a);
  } else if (tightness == ClipTightness::slab) {
    split_in_slab(triangle, axis, cell.lo[axis], position, cell.hi[axis], below_limit, above_limit,
                  b, a);
  } else {
    const ClipTriangle tri(triangle);
    Polygon poly;
    const int count = clip_to_box(tri, bounds, cell, poly);
    if (count <= 0) return;
    split_polygon(tri, poly.data(), count, axis, position, below_limit, above_limit, b, a);
  }
  if (!b.empty()) below = b;
  if (!a.empty()) above = a;
}

// The same with no known part: the exact split.
inline void clip_triangle_split(const Triangle& triangle, const Aabb& cell, int axis,
                                float position, Aabb& below, Aabb& above) {
  clip_triangle_split(triangle, cell, triangle.bounds(), axis, position, below, above,
                      ClipTightness::exact);
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
  constexpr double kInf = std::numeric_limits<double>::infinity();
  split_in_slab(triangle, axis, -kInf, position, kInf, left_limit, right_limit, left, right);
}

// The SBVH's spatial binning: an estimate of the bounds of the triangle's part on each side of
// `position` on `axis`, cut to `box` (the reference's box): in float, rounded to nearest. It only
// rates candidate splits, binned plane by plane (the part above one plane chopped again at the
// next); the references a chosen split makes are clipped conservatively by
// split_triangle_bounds. Kept out of line: inlined into the binning loop it ran slower.
[[gnu::noinline]] inline void split_triangle_estimate(const Triangle& triangle, const Aabb& box,
                                                      int axis, float position, Aabb& below,
                                                      Aabb& above) {
  Aabb l, r;
  for (int i = 0; i < 3; ++i) {
    const Vec3 a = triangle.vertex(i), b = triangle.vertex(i == 2 ? 0 : i + 1);
    const float pa = a[axis], pb = b[axis];
    if (pa <= position) l.extend(a);
    if (pa >= position) r.extend(a);
    if ((pa < position && pb > position) || (pa > position && pb < position)) {
      Vec3 q = a + (b - a) * ((position - pa) / (pb - pa));
      q = max(min(q, max(a, b)), min(a, b));  // on the edge despite rounding
      q[axis] = position;
      l.extend(q);
      r.extend(q);
    }
  }
  Aabb below_box = box, above_box = box;
  below_box.hi[axis] = std::min(below_box.hi[axis], position);
  above_box.lo[axis] = std::max(above_box.lo[axis], position);
  below = intersection(l, below_box);
  above = intersection(r, above_box);
  if (below.empty()) below = {};
  if (above.empty()) above = {};
}

}  // namespace splitray

// Conservative clipping (accel/triangle_clip.hpp) against a reference computed in long double
// (64-bit mantissa) without any rounding outward: on hostile triangles (a few ulps thick,
// slivers, far from the origin) and boxes whose planes pass through their vertices or a few
// ulps beside them, every clipped box must contain the reference polygon, be flat on an axis
// only where the exact intersection is, and stay within a few ulps of the reference.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "hostile_geometry.hpp"
#include "splitray/accel/triangle_clip.hpp"
#include "splitray/core/random.hpp"

namespace splitray {
namespace {

using Real = long double;

struct RPoint {
  Real p[3];
};

// Sutherland-Hodgman in long double, rounded to nearest: the reference polygon.
std::vector<RPoint> clip_reference(std::vector<RPoint> poly, int axis, Real plane,
                                   bool keep_above) {
  std::vector<RPoint> out;
  const auto inside = [&](const RPoint& v) {
    return keep_above ? v.p[axis] >= plane : v.p[axis] <= plane;
  };
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const RPoint& a = poly[i];
    const RPoint& b = poly[(i + 1) % poly.size()];
    if (inside(a)) out.push_back(a);
    if (inside(a) != inside(b)) {
      const Real t = (plane - a.p[axis]) / (b.p[axis] - a.p[axis]);
      RPoint c;
      for (int j = 0; j < 3; ++j) c.p[j] = a.p[j] + (b.p[j] - a.p[j]) * t;
      c.p[axis] = plane;
      out.push_back(c);
    }
  }
  return out;
}

std::vector<RPoint> reference_polygon(const Triangle& t, const Aabb& box) {
  std::vector<RPoint> poly;
  for (int i = 0; i < 3; ++i) poly.push_back({{t.vertex(i).x, t.vertex(i).y, t.vertex(i).z}});
  for (int axis = 0; axis < 3; ++axis) {
    if (!poly.empty()) poly = clip_reference(poly, axis, box.lo[axis], true);
    if (!poly.empty()) poly = clip_reference(poly, axis, box.hi[axis], false);
  }
  return poly;
}

// A box around (part of) a triangle: each plane at a vertex coordinate, a few ulps beside
// one, or anywhere across the triangle's extent.
Aabb random_box(const Triangle& t, Pcg32& rng) {
  const Aabb tb = t.bounds();
  Aabb box;
  for (int a = 0; a < 3; ++a) {
    const auto pick = [&] {
      const float v = t.vertex(static_cast<int>(rng.next_u32() % 3))[a];
      switch (rng.next_u32() % 4) {
        case 0:
          return v;
        case 1: {
          float x = v;
          for (int k = static_cast<int>(rng.next_u32() % 5) - 2; k != 0; k += k > 0 ? -1 : 1)
            x = std::nextafter(x, k > 0 ? tb.hi[a] + 1 : tb.lo[a] - 1);
          return x;
        }
        default:
          return tb.lo[a] + (tb.hi[a] - tb.lo[a]) * (1.4f * rng.next_float() - 0.2f);
      }
    };
    float p = pick(), q = pick();
    if (p > q) std::swap(p, q);
    box.lo[a] = p, box.hi[a] = q;
  }
  return box;
}

struct Checks {
  std::size_t boxes = 0, loose = 0;
  Real worst = 0;  // the largest excess over the exact bounds, in ulps of the coordinates
};

// `got` (clipped to `limit`) against the reference polygon `ref` of the same region.
void check(const Triangle& t, const std::vector<RPoint>& ref, const Aabb& got, const Aabb& limit,
           Checks& checks, const char* what) {
  if (ref.empty()) return;  // nothing to contain (a fallback to the overlap is conservative)
  ++checks.boxes;
  const Aabb tb = t.bounds();
  Real mag = 0;
  for (int a = 0; a < 3; ++a)
    mag = std::max({mag, std::fabs(Real(tb.lo[a])), std::fabs(Real(tb.hi[a]))});
  const Real tol = mag * 0x1p-60L;
  bool loose = false;
  for (int a = 0; a < 3; ++a) {
    Real lo = ref[0].p[a], hi = ref[0].p[a];
    for (const RPoint& v : ref) lo = std::min(lo, v.p[a]), hi = std::max(hi, v.p[a]);
    lo = std::max(lo, Real(limit.lo[a]));
    hi = std::min(hi, Real(limit.hi[a]));
    ASSERT_LE(Real(got.lo[a]), lo + tol)
        << what << " axis " << a << " lower bound cuts the triangle";
    ASSERT_GE(Real(got.hi[a]), hi - tol)
        << what << " axis " << a << " upper bound cuts the triangle";
    if (tb.lo[a] < tb.hi[a] && got.lo[a] == got.hi[a]) {
      ASSERT_LE(hi - lo, tol) << what << " axis " << a << ": flat box of a triangle that is not";
    }
    // Tight: at most two floats beyond the reference on each side.
    const float two_below =
        std::nextafter(std::nextafter(static_cast<float>(lo), -INFINITY), -INFINITY);
    const float two_above =
        std::nextafter(std::nextafter(static_cast<float>(hi), INFINITY), INFINITY);
    if (got.lo[a] < two_below || got.hi[a] > two_above) loose = true;
    // Never loose by more than a few ulps of the coordinates.
    const Real excess = std::max(lo - Real(got.lo[a]), Real(got.hi[a]) - hi);
    checks.worst = std::max(checks.worst, excess / (mag * 0x1p-23L));
  }
  checks.loose += loose ? 1 : 0;
}

TEST(ConservativeClip, BoxesContainTheExactIntersectionOfHostileTriangles) {
  Pcg32 rng(19);
  Checks box_checks, split_checks, sbvh_checks, slab_checks;
  for (int m = 0; m < 32; ++m) {
    const test::HostileMesh mesh = test::hostile_mesh(0xc11f, m);
    for (const Triangle& t : mesh.tris) {
      for (int k = 0; k < 24; ++k) {
        const Aabb box = random_box(t, rng);
        const Aabb overlap = intersection(t.bounds(), box);
        const Aabb got = clip_triangle_bounds(t, box);
        if (overlap.empty()) {
          ASSERT_TRUE(got.empty());
          continue;
        }
        check(t, reference_polygon(t, box), got, overlap, box_checks, "clip_triangle_bounds");

        // The same box split at a plane through it, as a kd builder splits a straddler.
        const int axis = static_cast<int>(rng.next_u32() % 3);
        const float position = box.lo[axis] + (box.hi[axis] - box.lo[axis]) * rng.next_float();
        Aabb below, above;
        clip_triangle_split(t, box, axis, position, below, above);
        Aabb below_cell = box, above_cell = box;
        below_cell.hi[axis] = position;
        above_cell.lo[axis] = position;
        check(t, reference_polygon(t, below_cell), below, intersection(t.bounds(), below_cell),
              split_checks, "clip_triangle_split below");
        check(t, reference_polygon(t, above_cell), above, intersection(t.bounds(), above_cell),
              split_checks, "clip_triangle_split above");

        // The fast builders' split of the box clipped before (looser, never cutting).
        Aabb slab_below, slab_above;
        clip_triangle_split(t, box, got, axis, position, slab_below, slab_above,
                            ClipTightness::slab);
        check(t, reference_polygon(t, below_cell), slab_below, intersection(t.bounds(), below_cell),
              slab_checks, "slab split below");
        check(t, reference_polygon(t, above_cell), slab_above, intersection(t.bounds(), above_cell),
              slab_checks, "slab split above");

        // The SBVH's split of a whole triangle's reference at the same plane.
        Aabb left, right;
        const Aabb tb = t.bounds();
        const float p = tb.lo[axis] + (tb.hi[axis] - tb.lo[axis]) * rng.next_float();
        split_triangle_bounds(t, tb, axis, p, left, right);
        Aabb left_cell = tb, right_cell = tb;
        left_cell.hi[axis] = p;
        right_cell.lo[axis] = p;
        check(t, reference_polygon(t, left_cell), left, intersection(tb, left_cell), sbvh_checks,
              "split_triangle_bounds left");
        check(t, reference_polygon(t, right_cell), right, intersection(tb, right_cell), sbvh_checks,
              "split_triangle_bounds right");
      }
    }
  }
  // Conservative, not sloppy: nearly every box within two floats of the exact bounds, and none
  // more than four ulps of its coordinates' magnitude beyond them.
  for (const Checks* c : {&box_checks, &split_checks, &sbvh_checks}) {
    EXPECT_GT(c->boxes, 20000u);
    EXPECT_LT(c->loose, c->boxes / 1000) << c->loose << " of " << c->boxes << " boxes are loose";
    EXPECT_LE(c->worst, 4) << "largest excess over the exact bounds, in ulps of the coordinates";
  }
  EXPECT_GT(slab_checks.boxes, 20000u);  // contained (checked above); looser by design
}

// The defect of issue #19 in miniature: a large triangle two ulps thick in y, cut by planes in
// x and z; float clipping rounded the crossings onto its top and returned a flat box.
TEST(ConservativeClip, AThinTriangleNeverGetsAFlatBox) {
  const float y = 0x1.34b11cp+2f, y2 = std::nextafter(std::nextafter(y, 10.0f), 10.0f);
  const Triangle t{{-10.7f, y2, -3.3f}, {-10.7f, y, 0.0f}, {-10.6f, y2, 0.0f}};
  Pcg32 rng(3);
  for (int i = 0; i < 100000; ++i) {
    Aabb box{{-10.7f + 0.1f * rng.next_float(), -100, -3.3f + 3.3f * rng.next_float()},
             {-10.6f, 100, 0.0f}};
    const Aabb b = clip_triangle_bounds(t, box);
    if (b.empty()) continue;
    const std::vector<RPoint> ref = reference_polygon(t, box);
    if (ref.empty()) continue;
    Real lo = ref[0].p[1], hi = ref[0].p[1];
    for (const RPoint& v : ref) lo = std::min(lo, v.p[1]), hi = std::max(hi, v.p[1]);
    ASSERT_LE(Real(b.lo[1]), lo) << i;
    ASSERT_GE(Real(b.hi[1]), hi) << i;
  }
}

}  // namespace
}  // namespace splitray

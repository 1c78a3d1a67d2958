#pragma once
// The conservative per-ray set-up of every traversal (kd-tree, BIH, BVH): one bound on the
// rounding a traversal must cover, and the two ways the structures widen their planes by it.
//
// The watertight triangle test decides hits on rounded, sheared vertex coordinates, and a
// traversal computes where the ray crosses planes in rounded arithmetic, so a hierarchy that
// clipped the ray exactly could skip a cell or box holding a hit that `brute` finds. Every
// plane is therefore moved outwards by `delta` = 2^-18 (the L1 distance from the origin to the
// far corner of the scene + the scene's largest coordinate), a bound on those errors (float
// rounding is 2^-24 of the same scale) that is still far below any cell that matters for speed.
//
// The inverse direction is finite: components below 2^-40 max|dir| are first made +-that (the
// same sign), a change of the ray's path far inside delta, so no 0 * inf makes a NaN.
//
// The two clip styles differ because the planes differ, not the bound:
// - Split planes (kd-trees): a plane is shared by the two cells it separates, so its crossing
//   t = (split - org[a]) * inv[a] is computed once and widened both ways: the cell the ray
//   leaves ends at t + pad[a], the one it enters starts at t - pad[a], with
//   pad[a] = delta |inv[a]| + delta / max|dir| (the second term covers the triangle test's t
//   placing a hit slightly outside its cell). The kd walks clip 7 (wide node) or 16 (packet)
//   planes per step from one t each, and the packet walk repeats these operations lane by lane.
// - Boxes and clip planes (BVH, BIH): entry and exit planes are separate numbers, so the origin
//   itself is moved, by -+delta along each axis's direction sign for entry planes (org_near)
//   and exit planes (org_far). Nothing is added per plane, and the wide BVH's slab test is one
//   fused multiply-subtract per plane with org * inv computed once per ray.
#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <cmath>
#include <limits>

#include "splitray/core/aabb.hpp"
#include "splitray/core/ray.hpp"

namespace splitray {

// The largest absolute coordinate of a box: rounding of stored bounds scales with it.
inline float coordinate_magnitude(const Aabb& box) {
  return std::max(max_component(abs(box.lo)), max_component(abs(box.hi)));
}

// max/min that keep `acc` when `x` is NaN.
inline float max_keep(float acc, float x) { return acc < x ? x : acc; }
inline float min_keep(float acc, float x) { return x < acc ? x : acc; }

// Whether the ray starts in `box` (as a ray leaving a surface of the scene does): SSE compares
// of the rows RobustRay loads too.
inline bool starts_inside(const Ray& ray, const Aabb& box) {
#if defined(__SSE2__)
  const __m128 o = _mm_setr_ps(ray.org.x, ray.org.y, ray.org.z, 0.0f);
  const __m128 lo = _mm_setr_ps(box.lo.x, box.lo.y, box.lo.z, 0.0f);
  const __m128 hi = _mm_setr_ps(box.hi.x, box.hi.y, box.hi.z, 0.0f);
  return _mm_movemask_ps(_mm_and_ps(_mm_cmple_ps(lo, o), _mm_cmple_ps(o, hi))) == 0xf;
#else
  return box.contains(ray.org);
#endif
}

struct RobustRay {
  Vec3 org;
  Vec3 inv;                // 1 / dir, finite (see above), signed like dir
  Vec3 org_near, org_far;  // boxes: the origin moved by -+delta along each direction sign
  int negative[3];         // 1 when the direction component is negative (or -0)
  float delta;             // the bound, in space
  float max_dir;           // max |dir|

  // False for rays with a NaN, infinite or zero direction or origin, which have no finite
  // inverse or bound (the kd-tree tests every reference for them; the Accel interface never
  // passes them).
  static bool traversable(const Ray& ray) {
    return is_finite(ray.org) && is_finite(ray.dir) && max_component(abs(ray.dir)) > 0;
  }

  // `scene` bounds every primitive; `magnitude` is coordinate_magnitude(scene). The BVH's
  // packets and groups repeat these operations for several rays at once (slab_lanes in
  // bvh/wide_bvh_walk.hpp): a change here must be made there too.
  RobustRay(const Ray& ray, const Aabb& scene, float magnitude) {
    org = ray.org;
    max_dir = max_component(abs(ray.dir));
    const float tiny = std::max(max_dir * 0x1p-40f, std::numeric_limits<float>::min());
#if defined(__SSE2__)
    // The same IEEE operations as the scalar code below, three lanes at once (one division
    // instead of three, no branches on the signs): the per-ray cost of a short diffuse ray.
    const __m128 o = _mm_setr_ps(ray.org.x, ray.org.y, ray.org.z, 0.0f);
    const __m128 d = _mm_setr_ps(ray.dir.x, ray.dir.y, ray.dir.z, 1.0f);
    const __m128 sign = _mm_set1_ps(-0.0f);
    const __m128 to_lo =
        _mm_andnot_ps(sign, _mm_sub_ps(o, _mm_setr_ps(scene.lo.x, scene.lo.y, scene.lo.z, 0.0f)));
    const __m128 to_hi =
        _mm_andnot_ps(sign, _mm_sub_ps(o, _mm_setr_ps(scene.hi.x, scene.hi.y, scene.hi.z, 0.0f)));
    alignas(16) float far[4];
    _mm_store_ps(far, _mm_max_ps(to_lo, to_hi));
    delta = 0x1p-18f * (far[0] + far[1] + far[2] + magnitude);
    const __m128 dir_sign = _mm_and_ps(d, sign);
    const __m128 small = _mm_cmplt_ps(_mm_andnot_ps(sign, d), _mm_set1_ps(tiny));
    const __m128 safe = _mm_or_ps(_mm_and_ps(small, _mm_or_ps(_mm_set1_ps(tiny), dir_sign)),
                                  _mm_andnot_ps(small, d));
    const __m128 step = _mm_or_ps(dir_sign, _mm_set1_ps(delta));  // +-delta by sign
    alignas(16) float inv4[4], near4[4], far4[4];
    _mm_store_ps(inv4, _mm_div_ps(_mm_set1_ps(1.0f), safe));
    _mm_store_ps(near4, _mm_add_ps(o, step));
    _mm_store_ps(far4, _mm_sub_ps(o, step));
    const int signs = _mm_movemask_ps(d);
    for (int a = 0; a < 3; ++a) negative[a] = (signs >> a) & 1;
    inv = {inv4[0], inv4[1], inv4[2]};
    org_near = {near4[0], near4[1], near4[2]};
    org_far = {far4[0], far4[1], far4[2]};
#else
    const Vec3 far = max(abs(ray.org - scene.lo), abs(ray.org - scene.hi));
    delta = 0x1p-18f * (far.x + far.y + far.z + magnitude);
    for (int a = 0; a < 3; ++a) {
      negative[a] = std::signbit(ray.dir[a]) ? 1 : 0;
      float d = ray.dir[a];
      if (std::fabs(d) < tiny) d = std::copysign(tiny, d);
      inv[a] = 1.0f / d;
      const float step = negative[a] ? -delta : delta;
      org_near[a] = ray.org[a] + step;
      org_far[a] = ray.org[a] - step;
    }
#endif
  }

  // Boxes: the entry and exit parameters of the ray on the slab [lo, hi] of axis a (entry > exit:
  // missed).
  float entry(int a, float lo, float hi) const {
    return ((negative[a] ? hi : lo) - org_near[a]) * inv[a];
  }
  float exit(int a, float lo, float hi) const {
    return ((negative[a] ? lo : hi) - org_far[a]) * inv[a];
  }

  // Split planes: the per-axis margin in t, and the ray's interval [t0, t1] in a root cell.
  struct Splits {
    float pad[3];
    float t0, t1;  // empty when !(t0 <= t1)
  };
  Splits splits(const Aabb& root, float tmin, float tmax) const {
    Splits s;
    const float pad_t = delta / max_dir;
    s.t0 = tmin;
    s.t1 = tmax;
    for (int a = 0; a < 3; ++a) {
      s.pad[a] = delta * std::fabs(inv[a]) + pad_t;
      const float ta = (root.lo[a] - org[a]) * inv[a], tb = (root.hi[a] - org[a]) * inv[a];
      const float enter = std::min(ta, tb) - s.pad[a], leave = std::max(ta, tb) + s.pad[a];
      if (enter > s.t0) s.t0 = enter;
      if (leave < s.t1) s.t1 = leave;
    }
    return s;
  }
};

}  // namespace splitray

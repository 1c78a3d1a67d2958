#pragma once
// Per-ray constants of a conservative slab test, shared by the BVH and the BIH.
//
// The watertight triangle test decides hits on rounded, sheared vertex coordinates, so it
// may report a hit for a ray that misses the exact triangle by a few ulps of the distance
// between the ray origin and the triangle. A box or clip plane must then still let that ray
// through, or a hierarchy would lose hits that `brute` finds. Every plane is therefore moved
// outwards by `pad`, a bound on those errors (32x margin) that grows with the distance from
// the origin to the scene: entry planes are measured from `org_near` (the origin moved
// forwards), exit planes from `org_far` (moved backwards). NaN from 0 * inf (a ray parallel
// to a plane that starts on it) is ignored by the min/max order of the slab test.
#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <cmath>

#include "splitray/core/aabb.hpp"
#include "splitray/core/ray.hpp"

namespace splitray {

// The largest absolute coordinate of a box: rounding of stored bounds scales with it.
inline float coordinate_magnitude(const Aabb& box) {
  return std::max(max_component(abs(box.lo)), max_component(abs(box.hi)));
}

struct RobustRay {
  Vec3 inv;                // 1 / dir (+-inf for a zero component, signed like the component)
  Vec3 org_near, org_far;  // origin moved by -+pad along each axis's direction sign
  int negative[3];         // 1 when the direction component is negative (or -0)

  // `scene` bounds every primitive; `magnitude` is coordinate_magnitude(scene).
  RobustRay(const Ray& ray, const Aabb& scene, float magnitude) {
#if defined(__SSE2__)
    // The same IEEE operations as the scalar code below, three lanes at once (one division
    // instead of three, no branches on the signs): the per-ray cost of a short diffuse ray.
    const __m128 org = _mm_setr_ps(ray.org.x, ray.org.y, ray.org.z, 0.0f);
    const __m128 dir = _mm_setr_ps(ray.dir.x, ray.dir.y, ray.dir.z, 1.0f);
    const __m128 sign = _mm_set1_ps(-0.0f);
    const __m128 to_lo =
        _mm_andnot_ps(sign, _mm_sub_ps(org, _mm_setr_ps(scene.lo.x, scene.lo.y, scene.lo.z, 0.0f)));
    const __m128 to_hi =
        _mm_andnot_ps(sign, _mm_sub_ps(org, _mm_setr_ps(scene.hi.x, scene.hi.y, scene.hi.z, 0.0f)));
    alignas(16) float far_side[4];
    _mm_store_ps(far_side, _mm_max_ps(to_lo, to_hi));
    const float reach = std::max(std::max(far_side[0], far_side[1]), far_side[2]);
    const float pad = 0x1p-18f * (reach + magnitude);
    const __m128 step = _mm_or_ps(_mm_and_ps(dir, sign), _mm_set1_ps(pad));  // +-pad by sign
    alignas(16) float inv4[4], near4[4], far4[4];
    _mm_store_ps(inv4, _mm_div_ps(_mm_set1_ps(1.0f), dir));
    _mm_store_ps(near4, _mm_add_ps(org, step));
    _mm_store_ps(far4, _mm_sub_ps(org, step));
    const int signs = _mm_movemask_ps(dir);
    for (int a = 0; a < 3; ++a) negative[a] = (signs >> a) & 1;
    inv = {inv4[0], inv4[1], inv4[2]};
    org_near = {near4[0], near4[1], near4[2]};
    org_far = {far4[0], far4[1], far4[2]};
#else
    float reach = 0;  // the largest coordinate distance from the origin to the scene
    for (int a = 0; a < 3; ++a)
      reach = std::max(reach, std::max(std::fabs(ray.org[a] - scene.lo[a]),
                                       std::fabs(ray.org[a] - scene.hi[a])));
    const float pad = 0x1p-18f * (reach + magnitude);
    for (int a = 0; a < 3; ++a) {
      negative[a] = std::signbit(ray.dir[a]) ? 1 : 0;
      inv[a] = 1.0f / ray.dir[a];
      const float step = negative[a] ? -pad : pad;
      org_near[a] = ray.org[a] + step;
      org_far[a] = ray.org[a] - step;
    }
#endif
  }

  // Entry and exit parameters of the ray on a slab [lo, hi] of axis a (entry > exit: missed).
  float entry(int a, float lo, float hi) const {
    return ((negative[a] ? hi : lo) - org_near[a]) * inv[a];
  }
  float exit(int a, float lo, float hi) const {
    return ((negative[a] ? lo : hi) - org_far[a]) * inv[a];
  }
};

// max/min that keep `acc` when `x` is NaN.
inline float max_keep(float acc, float x) { return acc < x ? x : acc; }
inline float min_keep(float acc, float x) { return x < acc ? x : acc; }

}  // namespace splitray

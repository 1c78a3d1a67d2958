#pragma once
// The coordinates and rays every structure answers exactly (issue #23).
//
// The watertight triangle test multiplies three coordinate differences (a sheared vertex
// minus the ray's origin, times an edge-function product). With vertices within +-2^36, ray
// origins within +-2^40 and the direction's largest component within [2^-2, 2^2] those
// products stay below 2^127, finite in float, so every structure and brute force compute the
// same t (every bound is derived in coordinates.cpp). Meshes, frames and scene transforms with
// vertices beyond the limit are rejected where they are read (an error naming the file);
// Accel rescales every other direction by an exact power of two (t is unchanged) and makes
// rays outside the domain (NaN or inf components, a zero direction, an origin beyond the
// limit, an empty interval) miss, so no traversal ever sees the non-finite slab values that would
// let it enter empty slots or push without bound.
#include <cmath>
#include <cstddef>
#include <span>
#include <string>

#include "splitray/core/ray.hpp"
#include "splitray/core/vec.hpp"

namespace splitray {

struct Triangle;

inline constexpr float kMaxCoordinate = 0x1p36f;  // vertices: about 6.9e10
inline constexpr float kMaxRayOrigin = 0x1p40f;   // ray origins: about 1.1e12

inline bool within(const Vec3& p, float limit) {
  // false for NaN too: every comparison with NaN is false
  return std::fabs(p.x) <= limit && std::fabs(p.y) <= limit && std::fabs(p.z) <= limit;
}
inline bool within_coordinate_limit(const Vec3& p) { return within(p, kMaxCoordinate); }

// Whether structures trace the ray (after rescaling its direction); any other ray misses
// and is never occluded.
//
// max|dir| is taken with comparisons (max_component), not std::fmax, which GCC calls through
// the PLT on every ray of every call; a NaN component is caught by the isnan tests either way.
inline bool traceable(const Ray& r) {
  const float d = max_component(abs(r.dir));
  return within(r.org, kMaxRayOrigin) && d > 0 && d <= 0x1p127f && !std::isnan(r.dir.x) &&
         !std::isnan(r.dir.y) && !std::isnan(r.dir.z) && r.tmin <= r.tmax;  // false for NaN
}

// The power of two by which a traceable ray's direction is multiplied so that its largest
// component lies in [2^-2, 2^2]: 0 (no change) for most rays, else the exponent that brings it
// to [1, 2). Scaling by a power of two is exact, so t = t_scaled * 2^k exactly.
inline int direction_exponent(const Ray& r) {
  const float d = max_component(abs(r.dir));
  if (d >= 0x1p-2f && d <= 0x1p2f) return 0;
  int e = 0;
  std::frexp(d, &e);  // d = m * 2^e with m in [0.5, 1)
  return 1 - e;
}

// traceable(r) && direction_exponent(r) == 0 for every ray: the batched calls' test for the
// common case of rays they hand the structures as given (with AVX-512 two rays per vector: the
// test ray by ray took 5-6 ns a ray, a fifth of a batched primary ray's time).
bool all_as_given(std::span<const Ray> rays);

// The ray with its direction multiplied by 2^k and its interval divided by it.
inline Ray scaled_ray(const Ray& r, int k) {
  return Ray{r.org, r.dir * std::ldexp(1.0f, k), std::ldexp(r.tmin, -k), std::ldexp(r.tmax, -k)};
}

// "a NaN or infinite coordinate" / "a coordinate of magnitude 2e+13, beyond ...": why p is
// refused as a vertex, for an error that names the file; empty when p is within the limit.
std::string coordinate_problem(const Vec3& p);
// The same for a ray origin or camera position (limit kMaxRayOrigin).
std::string origin_problem(const Vec3& p);

// Throws Error(where, ...) naming the first triangle with a coordinate outside the limit.
void check_triangles(std::span<const Triangle> triangles, const std::string& where);

}  // namespace splitray

#pragma once
// Triangles and the watertight ray-triangle test of Woop, Benthin and Wald (JCGT 2013):
// rays through a shared edge or vertex hit at least one of the triangles that share it.
#include <cmath>
#include <utility>

#include "splitray/core/aabb.hpp"
#include "splitray/core/ray.hpp"

namespace splitray {

struct Triangle {
  Vec3 v0, v1, v2;

  Aabb bounds() const {
    Aabb b;
    b.extend(v0);
    b.extend(v1);
    b.extend(v2);
    return b;
  }
  Vec3 geometric_normal() const { return cross(v1 - v0, v2 - v0); }  // not normalised
  float area() const { return 0.5f * length(geometric_normal()); }
  Vec3 vertex(int i) const { return i == 0 ? v0 : (i == 1 ? v1 : v2); }
};

// Per-ray constants of the watertight test: the ray is sheared so that it runs along +z.
struct WatertightRay {
  Vec3 org;
  int kx, ky, kz;
  float sx, sy, sz;

  // Made without branches on the direction (max_axis, the swap): a diffuse ray's direction is
  // random, and such branches are mispredicted about half the time. WatertightLanes
  // (triangle_simd.hpp) makes the same float operations for several rays at once: a change here
  // must be made there too.
  explicit WatertightRay(const Ray& ray) : org(ray.org) {
    const float d[3] = {ray.dir.x, ray.dir.y, ray.dir.z};  // indexed without branches
    const int largest = max_axis(abs(ray.dir));
    set_axes(largest, d[largest] < 0);
    sx = d[kx] / d[kz];
    sy = d[ky] / d[kz];
    sz = 1.0f / d[kz];
  }
  // From the parts made elsewhere: the direction's largest axis, whether the direction is
  // negative along it, and the three quotients.
  WatertightRay(const Vec3& origin, int largest, bool negative, float x, float y, float z)
      : org(origin), sx(x), sy(y), sz(z) {
    set_axes(largest, negative);
  }

 private:
  void set_axes(int largest, bool negative) {
    kz = largest;
    const int next = kz + 1 - 3 * static_cast<int>(kz == 2), after = 3 - kz - next;
    const int swap = -static_cast<int>(negative);  // keep the winding of the triangles
    kx = next ^ ((next ^ after) & swap);
    ky = after ^ ((next ^ after) & swap);
  }
};

// Tests the ray against the triangle for tmin <= t <= tmax. On a hit stores t and the
// barycentrics (u of v1, v of v2) and returns true. Both faces are hit.
//
// Two cases are decided in double precision, where the float edge functions cannot be
// trusted: an edge function exactly zero (the ray through an edge or a vertex: watertight),
// and a determinant small against the products it comes from (8 |det| < the sum of their
// magnitudes: a sliver or a triangle seen nearly edge-on). In the second case the float
// barycentrics are rounding noise, and a hit reported from them may lie far outside the
// triangle, where no hierarchy's cell holding the triangle reaches. In double the products
// are exact; a triangle still degenerate there (|det| < 2^-26 of them: collinear or seen
// exactly edge-on) is not hit, so every structure and brute force agree that it is missed.
inline bool intersect_triangle(const WatertightRay& r, const Triangle& tri, float tmin, float tmax,
                               float& t_out, float& u_out, float& v_out) {
  const Vec3 a = tri.v0 - r.org, b = tri.v1 - r.org, c = tri.v2 - r.org;
  const float ax = a[r.kx] - r.sx * a[r.kz], ay = a[r.ky] - r.sy * a[r.kz];
  const float bx = b[r.kx] - r.sx * b[r.kz], by = b[r.ky] - r.sy * b[r.kz];
  const float cx = c[r.kx] - r.sx * c[r.kz], cy = c[r.ky] - r.sy * c[r.kz];
  const float u1 = cx * by, u2 = cy * bx, v1 = ax * cy, v2 = ay * cx, w1 = bx * ay, w2 = by * ax;
  float u = u1 - u2;
  float v = v1 - v2;
  float w = w1 - w2;
  bool in_double = u == 0.0f || v == 0.0f || w == 0.0f;
  if (!in_double) {
    if ((u < 0 || v < 0 || w < 0) && (u > 0 || v > 0 || w > 0)) return false;
    const float magnitude = (std::fabs(u1) + std::fabs(u2)) + (std::fabs(v1) + std::fabs(v2)) +
                            (std::fabs(w1) + std::fabs(w2));
    in_double = 8.0f * std::fabs(u + v + w) < magnitude;
  }
  if (in_double) {
    const double du1 = static_cast<double>(cx) * by, du2 = static_cast<double>(cy) * bx;
    const double dv1 = static_cast<double>(ax) * cy, dv2 = static_cast<double>(ay) * cx;
    const double dw1 = static_cast<double>(bx) * ay, dw2 = static_cast<double>(by) * ax;
    const double du = du1 - du2, dv = dv1 - dv2, dw = dw1 - dw2;
    const double magnitude = std::fabs(du1) + std::fabs(du2) + std::fabs(dv1) + std::fabs(dv2) +
                             std::fabs(dw1) + std::fabs(dw2);
    if (!(std::fabs(du + dv + dw) * 0x1p26 >= magnitude)) return false;  // degenerate
    u = static_cast<float>(du);
    v = static_cast<float>(dv);
    w = static_cast<float>(dw);
  }
  if ((u < 0 || v < 0 || w < 0) && (u > 0 || v > 0 || w > 0)) return false;
  const float det = u + v + w;
  if (det == 0.0f) return false;
  const float az = r.sz * a[r.kz], bz = r.sz * b[r.kz], cz = r.sz * c[r.kz];
  const float t_scaled = u * az + v * bz + w * cz;
  const float inv_det = 1.0f / det;
  const float t = t_scaled * inv_det;
  if (!(t >= tmin && t <= tmax)) return false;  // also rejects NaN
  t_out = t;
  u_out = v * inv_det;
  v_out = w * inv_det;
  return true;
}

// Convenience: closest-hit update of `hit` with triangle `prim` under the tie rule of Hit.
inline bool intersect_triangle(const WatertightRay& r, const Triangle& tri, std::uint32_t prim,
                               float tmin, Hit& hit) {
  Hit candidate;
  if (!intersect_triangle(r, tri, tmin, hit.t, candidate.t, candidate.u, candidate.v)) return false;
  candidate.prim = prim;
  if (!candidate.closer_than(hit)) return false;
  hit = candidate;
  return true;
}

}  // namespace splitray

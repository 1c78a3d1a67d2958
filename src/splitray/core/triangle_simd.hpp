#pragma once
// The watertight test of triangle.hpp on eight triangles at once, for the leaves of the
// kd-tree and the BVH, whatever their layout (a loader gives the eight values of one vertex
// coordinate), and on sixteen rays at once for the BVH's packets. Lane by lane it performs
// exactly the scalar test's float operations in the same order (the project builds without FMA
// contraction), so t, u and v are bit-identical to it;
// the lanes the scalar test decides in double (an edge function exactly zero, or a determinant
// small against its products) are returned in `scalar` for the caller to hand to it.
#include "splitray/core/triangle.hpp"

#if defined(__AVX__)
#include "splitray/core/simd.hpp"

namespace splitray {

// The watertight test's float operations on a vector of (ray, triangle) pairs, a pair per
// lane: rel[vertex][i] is coordinate k_i of the vertex minus the ray origin's (the ray's axis
// order: x, y, then z, the largest direction component), sx, sy, sz the rays' shear. Returns
// the lanes of `valid` hit with tmin <= t <= tmax, their t, u and v stored in the arrays;
// `scalar` gets the lanes of `valid` the scalar test must decide.
// kEarlyOuts: return as soon as no lane is left (the choice of wide_bvh_walk.hpp's walk).
template <class F, bool kEarlyOuts = true>
[[gnu::always_inline]] inline unsigned watertight_lanes(const F (&rel)[3][3], F sx, F sy, F sz,
                                                        unsigned valid, F tmin, F tmax,
                                                        float* t_out, float* u_out, float* v_out,
                                                        unsigned& scalar) {
  const F az0 = rel[0][2], bz0 = rel[1][2], cz0 = rel[2][2];
  const F ax = rel[0][0] - sx * az0, ay = rel[0][1] - sy * az0;
  const F bx = rel[1][0] - sx * bz0, by = rel[1][1] - sy * bz0;
  const F cx = rel[2][0] - sx * cz0, cy = rel[2][1] - sy * cz0;
  const F u1 = cx * by, u2 = cy * bx;
  const F v1 = ax * cy, v2 = ay * cx;
  const F w1 = bx * ay, w2 = by * ax;
  const F u = u1 - u2, v = v1 - v2, w = w1 - w2;
  const F zero = F::zero();
  const unsigned edge = ((u == zero) | (v == zero) | (w == zero)).bits() & valid;
  scalar = edge;
  const unsigned negative = ((u < zero) | (v < zero) | (w < zero)).bits();
  const unsigned positive = ((u > zero) | (v > zero) | (w > zero)).bits();
  unsigned inside = valid & ~edge & ~(negative & positive);
  if (kEarlyOuts && !inside) return 0;
  const F det = u + v + w;
  const F magnitude = abs(u1) + abs(u2) + (abs(v1) + abs(v2)) + (abs(w1) + abs(w2));
  const unsigned ill = (F::broadcast(8.0f) * abs(det) < magnitude).bits();
  scalar |= ill & inside;
  inside &= ~ill;
  if (kEarlyOuts && !inside) return 0;
  const F t_scaled = u * (sz * az0) + v * (sz * bz0) + w * (sz * cz0);
  const F inv_det = F::broadcast(1.0f) / det;
  const F t = t_scaled * inv_det;
  const unsigned hits = ((det != zero) & ((t >= tmin) & (t <= tmax))).bits() & inside;
  if (!hits) return 0;
  t.storeu(t_out);
  (v * inv_det).storeu(u_out);
  (w * inv_det).storeu(v_out);
  return hits;
}

// One ray against eight triangles, a triangle per lane.
class Watertight8 {
 public:
  explicit Watertight8(const WatertightRay& r) : k_{r.kx, r.ky, r.kz} {
    const float o[3] = {r.org.x, r.org.y, r.org.z};
    for (int i = 0; i < 3; ++i) org_[i] = simd::Float8::broadcast(o[k_[i]]);
    sx_ = simd::Float8::broadcast(r.sx);
    sy_ = simd::Float8::broadcast(r.sy);
    sz_ = simd::Float8::broadcast(r.sz);
  }

  // load(vertex, axis) -> the eight lanes' coordinate `axis` (0-2) of vertex 0-2 (a Float8 or
  // __m256); the rest as watertight_lanes.
  template <bool kEarlyOuts = true, class Load>
  unsigned test(const Load& load, unsigned valid, float tmin, float tmax, float* t_out,
                float* u_out, float* v_out, unsigned& scalar) const {
    using simd::Float8;
    Float8 rel[3][3];
    for (int vertex = 0; vertex < 3; ++vertex)
      for (int i = 0; i < 3; ++i) rel[vertex][i] = Float8(load(vertex, k_[i])) - org_[i];
    return watertight_lanes<Float8, kEarlyOuts>(rel, sx_, sy_, sz_, valid, Float8::broadcast(tmin),
                                                Float8::broadcast(tmax), t_out, u_out, v_out,
                                                scalar);
  }

 private:
  int k_[3];             // kx, ky, kz
  simd::Float8 org_[3];  // org_[i] = origin[k_[i]]
  simd::Float8 sx_, sy_, sz_;
};

// WatertightRay's constants of several rays, a lane each (F: simd::Float8 or Float16), made
// for all of them at once (the BVH's groups make them before their rays' walks): lane by lane
// WatertightRay's float operations, so ray(lane, origin) equals WatertightRay(that ray) for a
// finite direction.
template <class F>
struct WatertightLanes {
  alignas(64) float s[3][F::kLanes];           // sx, sy, sz
  unsigned x_largest, y_largest, kz_negative;  // a bit per lane: the largest axis, its sign

  WatertightLanes() = default;  // unset
  explicit WatertightLanes(const F (&dir)[3]) {
    // max_axis lane by lane: x when |x| >= |y| and |x| >= |z|, else y when |y| >= |z|.
    const F ax = abs(dir[0]), ay = abs(dir[1]), az = abs(dir[2]);
    const auto x = (ax >= ay) & (ax >= az), y = (ax < ay) & (ay >= az);
    const auto pick = [&](F if_x, F if_y, F if_z) {
      return select(x, if_x, select(y, if_y, if_z));
    };
    const F d_kz = pick(dir[0], dir[1], dir[2]);
    const F d_next = pick(dir[1], dir[2], dir[0]), d_after = pick(dir[2], dir[0], dir[1]);
    const auto negative = d_kz < F::zero();  // then kx and ky swap, as in WatertightRay
    (select(negative, d_after, d_next) / d_kz).storeu(s[0]);
    (select(negative, d_next, d_after) / d_kz).storeu(s[1]);
    (F::broadcast(1.0f) / d_kz).storeu(s[2]);
    x_largest = x.bits();
    y_largest = y.bits();
    kz_negative = negative.bits();
  }

  WatertightRay ray(int lane, const Vec3& origin) const {
    const int kz = 2 - 2 * static_cast<int>(x_largest >> lane & 1u) -
                   static_cast<int>(y_largest >> lane & 1u);  // as max_axis
    return WatertightRay(origin, kz, (kz_negative >> lane & 1u) != 0, s[0][lane], s[1][lane],
                         s[2][lane]);
  }
};

#if defined(__AVX512F__)
// One triangle against sixteen rays, a ray per lane (Wald, Slusallek, Benthin & Wagner 2001;
// Embree's packet triangle tests), for packets whose rays share the watertight test's axis
// order; each lane computes WatertightRay's constants and the test with its float operations.
class WatertightPacket {
 public:
  using F = simd::Float16;
  // The rays' origins and directions, a lane each, and the axis order they share.
  WatertightPacket(const F (&org)[3], const F (&dir)[3], const int (&k)[3]) : k_{k[0], k[1], k[2]} {
    for (int i = 0; i < 3; ++i) org_[i] = org[k_[i]];
    sx_ = dir[k_[0]] / dir[k_[2]];
    sy_ = dir[k_[1]] / dir[k_[2]];
    sz_ = F::broadcast(1.0f) / dir[k_[2]];
  }
  // The axis order of WatertightRay for each lane's direction when the lanes of `lanes` share
  // one, else false.
  static bool shared_axes(const F (&dir)[3], unsigned lanes, int (&k)[3]);

  // coordinate(vertex, axis) -> that coordinate of the triangle (0-2 each), a float broadcast to
  // every lane; the rest as watertight_lanes.
  template <class Coordinate>
  unsigned test(const Coordinate& coordinate, unsigned valid, F tmin, F tmax, float* t_out,
                float* u_out, float* v_out, unsigned& scalar) const {
    F rel[3][3];
    for (int vertex = 0; vertex < 3; ++vertex)
      for (int i = 0; i < 3; ++i)
        rel[vertex][i] = F::broadcast(coordinate(vertex, k_[i])) - org_[i];
    return watertight_lanes(rel, sx_, sy_, sz_, valid, tmin, tmax, t_out, u_out, v_out, scalar);
  }

 private:
  int k_[3];
  F org_[3];
  F sx_, sy_, sz_;
};

inline bool WatertightPacket::shared_axes(const F (&dir)[3], unsigned lanes, int (&k)[3]) {
  // max_axis (vec.hpp) lane by lane: x when |x| >= |y| and |x| >= |z|, else y when |y| >= |z|.
  const F ax = abs(dir[0]), ay = abs(dir[1]), az = abs(dir[2]);
  const unsigned x_ge_y = (ax >= ay).bits();
  const unsigned x_largest = x_ge_y & (ax >= az).bits() & lanes;
  const unsigned y_largest = ~x_ge_y & (ay >= az).bits() & lanes;
  int kz;
  if (x_largest == lanes)
    kz = 0;
  else if (y_largest == lanes)
    kz = 1;
  else if ((x_largest | y_largest) == 0)
    kz = 2;
  else
    return false;
  const unsigned negative = (dir[kz] < F::zero()).bits() & lanes;
  if (negative != 0 && negative != lanes) return false;
  const int next = kz == 2 ? 0 : kz + 1, after = 3 - kz - next;
  k[0] = negative != 0 ? after : next;
  k[1] = negative != 0 ? next : after;
  k[2] = kz;
  return true;
}
#endif

}  // namespace splitray
#endif

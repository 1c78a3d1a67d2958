#pragma once
// The watertight test of triangle.hpp on eight triangles at once, for the leaves of the
// kd-tree and the BVH, whatever their layout (a loader gives the eight values of one vertex
// coordinate). Lane by lane it performs exactly the scalar test's float operations in the same
// order (the project builds without FMA contraction), so t, u and v are bit-identical to it;
// the lanes the scalar test decides in double (an edge function exactly zero, or a determinant
// small against its products) are returned in `scalar` for the caller to hand to it.
#include "splitray/core/triangle.hpp"

#if defined(__AVX__)
#include "splitray/core/simd.hpp"

namespace splitray {

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
  // __m256). Returns the lanes of `valid` hit with tmin <= t <= tmax, their t, u and v stored in
  // the arrays; `scalar` gets the lanes of `valid` the scalar test must decide.
  template <class Load>
  unsigned test(const Load& load, unsigned valid, float tmin, float tmax, float* t_out,
                float* u_out, float* v_out, unsigned& scalar) const {
    using simd::Float8;
    const auto rel = [&](int vertex, int i) { return Float8(load(vertex, k_[i])) - org_[i]; };
    const Float8 az0 = rel(0, 2), bz0 = rel(1, 2), cz0 = rel(2, 2);
    const Float8 ax = rel(0, 0) - sx_ * az0, ay = rel(0, 1) - sy_ * az0;
    const Float8 bx = rel(1, 0) - sx_ * bz0, by = rel(1, 1) - sy_ * bz0;
    const Float8 cx = rel(2, 0) - sx_ * cz0, cy = rel(2, 1) - sy_ * cz0;
    const Float8 u1 = cx * by, u2 = cy * bx;
    const Float8 v1 = ax * cy, v2 = ay * cx;
    const Float8 w1 = bx * ay, w2 = by * ax;
    const Float8 u = u1 - u2, v = v1 - v2, w = w1 - w2;
    const Float8 zero = Float8::zero();
    const unsigned edge = ((u == zero) | (v == zero) | (w == zero)).bits() & valid;
    scalar = edge;
    const unsigned negative = ((u < zero) | (v < zero) | (w < zero)).bits();
    const unsigned positive = ((u > zero) | (v > zero) | (w > zero)).bits();
    unsigned inside = valid & ~edge & ~(negative & positive);
    if (!inside) return 0;
    const Float8 det = u + v + w;
    const Float8 magnitude = abs(u1) + abs(u2) + (abs(v1) + abs(v2)) + (abs(w1) + abs(w2));
    const unsigned ill = (Float8::broadcast(8.0f) * abs(det) < magnitude).bits();
    scalar |= ill & inside;
    inside &= ~ill;
    if (!inside) return 0;
    const Float8 t_scaled = u * (sz_ * az0) + v * (sz_ * bz0) + w * (sz_ * cz0);
    const Float8 inv_det = Float8::broadcast(1.0f) / det;
    const Float8 t = t_scaled * inv_det;
    const unsigned hits =
        ((det != zero) & ((t >= Float8::broadcast(tmin)) & (t <= Float8::broadcast(tmax)))).bits() &
        inside;
    if (!hits) return 0;
    t.storeu(t_out);
    (v * inv_det).storeu(u_out);
    (w * inv_det).storeu(v_out);
    return hits;
  }

 private:
  int k_[3];             // kx, ky, kz
  simd::Float8 org_[3];  // org_[i] = origin[k_[i]]
  simd::Float8 sx_, sy_, sz_;
};

}  // namespace splitray
#endif

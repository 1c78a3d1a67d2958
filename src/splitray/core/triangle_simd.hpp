#pragma once
// The watertight test of triangle.hpp on eight triangles at once, for the leaves of the
// kd-tree and the BVH, whatever their layout (a loader gives the eight values of one vertex
// coordinate). Lane by lane it performs exactly the scalar test's float operations in the same
// order (the project builds without FMA contraction), so t, u and v are bit-identical to it;
// the lanes the scalar test decides in double (an edge function exactly zero, or a determinant
// small against its products) are returned in `scalar` for the caller to hand to it.
#include "splitray/core/triangle.hpp"

#if defined(__AVX__)
#include <immintrin.h>

namespace splitray {

class Watertight8 {
 public:
  explicit Watertight8(const WatertightRay& r) : k_{r.kx, r.ky, r.kz} {
    const float o[3] = {r.org.x, r.org.y, r.org.z};
    for (int i = 0; i < 3; ++i) org_[i] = _mm256_set1_ps(o[k_[i]]);
    sx_ = _mm256_set1_ps(r.sx);
    sy_ = _mm256_set1_ps(r.sy);
    sz_ = _mm256_set1_ps(r.sz);
  }

  // load(vertex, axis) -> the eight lanes' coordinate `axis` (0-2) of vertex 0-2. Returns the
  // lanes of `valid` hit with tmin <= t <= tmax, their t, u and v stored in the arrays;
  // `scalar` gets the lanes of `valid` the scalar test must decide.
  template <class Load>
  unsigned test(const Load& load, unsigned valid, float tmin, float tmax, float* t_out,
                float* u_out, float* v_out, unsigned& scalar) const {
    const auto rel = [&](int vertex, int i) { return _mm256_sub_ps(load(vertex, k_[i]), org_[i]); };
    const __m256 az0 = rel(0, 2), bz0 = rel(1, 2), cz0 = rel(2, 2);
    const __m256 ax = _mm256_sub_ps(rel(0, 0), _mm256_mul_ps(sx_, az0));
    const __m256 ay = _mm256_sub_ps(rel(0, 1), _mm256_mul_ps(sy_, az0));
    const __m256 bx = _mm256_sub_ps(rel(1, 0), _mm256_mul_ps(sx_, bz0));
    const __m256 by = _mm256_sub_ps(rel(1, 1), _mm256_mul_ps(sy_, bz0));
    const __m256 cx = _mm256_sub_ps(rel(2, 0), _mm256_mul_ps(sx_, cz0));
    const __m256 cy = _mm256_sub_ps(rel(2, 1), _mm256_mul_ps(sy_, cz0));
    const __m256 u1 = _mm256_mul_ps(cx, by), u2 = _mm256_mul_ps(cy, bx);
    const __m256 v1 = _mm256_mul_ps(ax, cy), v2 = _mm256_mul_ps(ay, cx);
    const __m256 w1 = _mm256_mul_ps(bx, ay), w2 = _mm256_mul_ps(by, ax);
    const __m256 u = _mm256_sub_ps(u1, u2), v = _mm256_sub_ps(v1, v2), w = _mm256_sub_ps(w1, w2);
    const __m256 zero = _mm256_setzero_ps();
    const auto any = [&](int predicate_lt_eq_gt) {
      const auto cmp = [&](__m256 x) {
        return predicate_lt_eq_gt < 0   ? _mm256_cmp_ps(x, zero, _CMP_LT_OQ)
               : predicate_lt_eq_gt > 0 ? _mm256_cmp_ps(x, zero, _CMP_GT_OQ)
                                        : _mm256_cmp_ps(x, zero, _CMP_EQ_OQ);
      };
      return static_cast<unsigned>(
          _mm256_movemask_ps(_mm256_or_ps(_mm256_or_ps(cmp(u), cmp(v)), cmp(w))));
    };
    const unsigned edge = any(0) & valid;
    scalar = edge;
    unsigned inside = valid & ~edge & ~(any(-1) & any(1));
    if (!inside) return 0;
    const __m256 det = _mm256_add_ps(_mm256_add_ps(u, v), w);
    const __m256 abs_mask = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff));
    const auto abs = [&](__m256 x) { return _mm256_and_ps(x, abs_mask); };
    const __m256 magnitude = _mm256_add_ps(
        _mm256_add_ps(_mm256_add_ps(abs(u1), abs(u2)), _mm256_add_ps(abs(v1), abs(v2))),
        _mm256_add_ps(abs(w1), abs(w2)));
    const unsigned ill = static_cast<unsigned>(_mm256_movemask_ps(
        _mm256_cmp_ps(_mm256_mul_ps(_mm256_set1_ps(8.0f), abs(det)), magnitude, _CMP_LT_OQ)));
    scalar |= ill & inside;
    inside &= ~ill;
    if (!inside) return 0;
    const __m256 t_scaled = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(u, _mm256_mul_ps(sz_, az0)),
                                                        _mm256_mul_ps(v, _mm256_mul_ps(sz_, bz0))),
                                          _mm256_mul_ps(w, _mm256_mul_ps(sz_, cz0)));
    const __m256 inv_det = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
    const __m256 t = _mm256_mul_ps(t_scaled, inv_det);
    const __m256 ok =
        _mm256_and_ps(_mm256_cmp_ps(det, zero, _CMP_NEQ_UQ),
                      _mm256_and_ps(_mm256_cmp_ps(t, _mm256_set1_ps(tmin), _CMP_GE_OQ),
                                    _mm256_cmp_ps(t, _mm256_set1_ps(tmax), _CMP_LE_OQ)));
    const unsigned hits = static_cast<unsigned>(_mm256_movemask_ps(ok)) & inside;
    if (!hits) return 0;
    _mm256_storeu_ps(t_out, t);
    _mm256_storeu_ps(u_out, _mm256_mul_ps(v, inv_det));
    _mm256_storeu_ps(v_out, _mm256_mul_ps(w, inv_det));
    return hits;
  }

 private:
  int k_[3];       // kx, ky, kz
  __m256 org_[3];  // org_[i] = origin[k_[i]]
  __m256 sx_, sy_, sz_;
};

}  // namespace splitray
#endif

#pragma once
// The tests of one ray against the wide layout (wide_bvh.hpp), shared by the single-ray walk
// (wide_bvh_traverse.cpp) and the packet walk (wide_bvh_packet.cpp), so that a ray enters the
// same children and tests the same triangles in both. The slab test of the AVX paths (with
// FMA) and of the scalar path round differently, but both stay within the padding of
// robust_ray.hpp (min/max operand order keeps NaN out), so both let every ray through to every
// triangle it may hit, and the answers come from the same watertight triangle test.
#if defined(__SSE__)
#include <immintrin.h>
#endif

#include <bit>
#include <cstddef>
#include <cstdint>

#include "splitray/accel/bvh/wide_bvh.hpp"
#include "splitray/accel/robust_ray.hpp"
#include "splitray/core/triangle_simd.hpp"

namespace splitray::wide_bvh {

// The per-ray constants of the wide slab test: plane rows by direction sign, and the
// origins and inverse direction broadcast once.
struct WideSlab {
  int near[3], far[3];
#if defined(__AVX512F__)
  __m512 org_near[3], org_far[3], inv[3];  // origin times inv
#elif defined(__AVX__)
  __m256 org_near[3], org_far[3], inv[3];  // org_*: origin times inv (FMA) or the origin
#endif
  const RobustRay& r;

  explicit WideSlab(const RobustRay& ray) : r(ray) {
    for (int a = 0; a < 3; ++a) {
      near[a] = r.negative[a] ? 3 + a : a;
      far[a] = r.negative[a] ? a : 3 + a;
#if defined(__AVX512F__)
      org_near[a] = _mm512_set1_ps(r.org_near[a] * r.inv[a]);
      org_far[a] = _mm512_set1_ps(r.org_far[a] * r.inv[a]);
      inv[a] = _mm512_set1_ps(r.inv[a]);
#elif defined(__AVX__)
#if defined(__FMA__)
      org_near[a] = _mm256_set1_ps(r.org_near[a] * r.inv[a]);
      org_far[a] = _mm256_set1_ps(r.org_far[a] * r.inv[a]);
#else
      org_near[a] = _mm256_set1_ps(r.org_near[a]);
      org_far[a] = _mm256_set1_ps(r.org_far[a]);
#endif
      inv[a] = _mm256_set1_ps(r.inv[a]);
#endif
    }
  }

  // Entry parameters into all slots (within [tmin, tmax]); bit i set on a hit.
  unsigned test(const WideNode& n, float tmin, float tmax, float* t_entry) const {
#if defined(__AVX512F__)
    __m512 t0 = _mm512_set1_ps(tmin), t1 = _mm512_set1_ps(tmax);
    for (int a = 0; a < 3; ++a) {
      const __m512 lo = _mm512_fmsub_ps(_mm512_load_ps(n.planes[near[a]]), inv[a], org_near[a]);
      const __m512 hi = _mm512_fmsub_ps(_mm512_load_ps(n.planes[far[a]]), inv[a], org_far[a]);
      // NaN in the first operand keeps t0 (as below); the zero-masked forms avoid a false
      // may-be-uninitialised warning of GCC 12's plain _mm512_max_ps.
      t0 = _mm512_maskz_max_ps(0xffff, lo, t0);
      t1 = _mm512_maskz_min_ps(0xffff, hi, t1);
    }
    _mm512_store_ps(t_entry, t0);
    return static_cast<unsigned>(_mm512_cmp_ps_mask(t0, t1, _CMP_LE_OQ));
#elif defined(__AVX__)
    __m256 t0 = _mm256_set1_ps(tmin), t1 = _mm256_set1_ps(tmax);
    for (int a = 0; a < 3; ++a) {
#if defined(__FMA__)
      // plane * inv - org * inv in one rounding: the extra error of rounding org * inv is
      // below 2^-24 |org inv|, 1/64 of the padding (robust_ray.hpp), so the test stays
      // conservative; a zero direction component gives NaN, which keeps the slot (safe).
      const __m256 lo = _mm256_fmsub_ps(_mm256_load_ps(n.planes[near[a]]), inv[a], org_near[a]);
      const __m256 hi = _mm256_fmsub_ps(_mm256_load_ps(n.planes[far[a]]), inv[a], org_far[a]);
      t0 = _mm256_max_ps(lo, t0);  // NaN in the first operand keeps t0
      t1 = _mm256_min_ps(hi, t1);
#else
      const __m256 lo = _mm256_sub_ps(_mm256_load_ps(n.planes[near[a]]), org_near[a]);
      const __m256 hi = _mm256_sub_ps(_mm256_load_ps(n.planes[far[a]]), org_far[a]);
      t0 = _mm256_max_ps(_mm256_mul_ps(lo, inv[a]), t0);  // NaN in the first operand keeps t0
      t1 = _mm256_min_ps(_mm256_mul_ps(hi, inv[a]), t1);
#endif
    }
    _mm256_store_ps(t_entry, t0);
    return static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(t0, t1, _CMP_LE_OQ)));
#else
    unsigned mask = 0;
    for (int i = 0; i < kWideWidth; ++i) {
      float t0 = tmin, t1 = tmax;
      for (int a = 0; a < 3; ++a) {
        t0 = max_keep(t0, (n.planes[near[a]][i] - r.org_near[a]) * r.inv[a]);
        t1 = min_keep(t1, (n.planes[far[a]][i] - r.org_far[a]) * r.inv[a]);
      }
      t_entry[i] = t0;
      if (t0 <= t1) mask |= 1u << i;
    }
    return mask;
#endif
  }
};

// Asks for the cache lines of a node, or of a leaf's first block, before they are needed.
template <std::size_t kBytes>
inline void prefetch(const void* p) {
#if defined(__SSE__)
  const char* c = static_cast<const char*>(p);
  for (std::size_t line = 0; line < kBytes; line += 64) _mm_prefetch(c + line, _MM_HINT_T0);
#else
  (void)p;
#endif
}

// The eight triangles of a block through the 8-wide watertight test (core/triangle_simd.hpp);
// the lanes it hands back, and without AVX every lane, go to the scalar test (the portable
// build tests one triangle at a time).
struct WatertightBlock {
#if defined(__AVX__)
  Watertight8 test8;
  explicit WatertightBlock(const WatertightRay& ray) : test8(ray) {}
  unsigned test(const TriangleBlock& b, float tmin, float tmax, float* t_out, float* u_out,
                float* v_out, unsigned& scalar) const {
    const auto load = [&](int vertex, int axis) { return _mm256_load_ps(b.v[3 * vertex + axis]); };
    return test8.test(load, (1u << kBlockWidth) - 1, tmin, tmax, t_out, u_out, v_out, scalar);
  }
#else
  explicit WatertightBlock(const WatertightRay&) {}
  unsigned test(const TriangleBlock&, float, float, float*, float*, float*,
                unsigned& scalar) const {
    scalar = (1u << kBlockWidth) - 1;
    return 0;
  }
#endif
};

// Tests the `count` blocks of a leaf for one ray with t in [tmin, best.t]. Closest hit: `best`
// becomes the closest hit under the tie rule of Hit; any hit: true at the first hit.
template <bool AnyHit>
[[gnu::always_inline]] inline bool test_leaf(const TriangleBlock* blocks, std::uint32_t count,
                                             const WatertightRay& w, const WatertightBlock& wb,
                                             float tmin, Hit& best) {
  for (std::uint32_t b = 0; b < count; ++b) {
    alignas(32) float t[kBlockWidth], u[kBlockWidth], v[kBlockWidth];
    unsigned scalar;
    const TriangleBlock& block = blocks[b];
    unsigned found = wb.test(block, tmin, best.t, t, u, v, scalar);
    while (scalar != 0) {  // edge cases: the scalar test decides in double precision
      const int lane = std::countr_zero(scalar);
      scalar &= scalar - 1;
      if (intersect_triangle(w, block.triangle(lane), tmin, best.t, t[lane], u[lane], v[lane]))
        found |= 1u << lane;
    }
    if constexpr (AnyHit) {
      if (found != 0) return true;
    } else {
      while (found != 0) {
        const int lane = std::countr_zero(found);
        found &= found - 1;
        const Hit candidate{t[lane], block.id[lane], u[lane], v[lane]};
        if (candidate.closer_than(best)) best = candidate;
      }
    }
  }
  return false;
}

}  // namespace splitray::wide_bvh

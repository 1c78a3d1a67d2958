#pragma once
// The leaves' triangles of a kd-tree in a SIMD-friendly layout, and the leaf test.
//
// Every leaf's n triangles are stored as 9 rows of n floats (v0.x, v0.y, v0.z, v1.x, ..., v2.z)
// at 9 * (the leaf's first index in KdTree::prim_ids), so a leaf needs no extra offset and 8
// triangles are loaded per row with one unaligned load (lanes past n read neighbouring rows or
// the padding at the end and are masked out).
//
// The 8-wide test performs, lane by lane, exactly the float operations of the scalar
// watertight test (core/triangle.hpp) in the same order (the project builds without FMA
// contraction), so t, u and v are bit-identical to it. Lanes where u, v or w is exactly zero
// (the scalar test's switch to double) are handed to the scalar test itself.
#include <cstdint>
#include <vector>

#include "splitray/core/huge_page_allocator.hpp"
#include "splitray/core/triangle.hpp"

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace splitray {

class KdLeafTriangles {
 public:
  static constexpr std::uint32_t kPadding = 16;  // floats after the last row

  KdLeafTriangles() = default;

  // Room for the rows of `refs` references in all (mapped once, zero padding at the end).
  void resize(std::size_t refs) { rows_.assign(9 * refs + kPadding, 0.0f); }

  // Writes the rows of the leaf whose n references start at `first` (ids: all references),
  // within the size of resize(). Leaves write disjoint rows, so they may be filled in parallel.
  void set_leaf(std::uint32_t first, std::uint32_t n, const std::uint32_t* ids,
                const Triangle* triangles) {
    float* rows = rows_.data() + 9 * std::size_t{first};
    for (std::uint32_t i = 0; i < n; ++i) {
      const Triangle& t = triangles[ids[first + i]];
      for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c) rows[(3 * k + c) * n + i] = t.vertex(k)[c];
    }
  }

  const float* leaf(std::uint32_t first) const { return rows_.data() + 9 * std::size_t{first}; }
  std::size_t bytes() const { return rows_.size() * sizeof(float); }

  // Triangle i of the leaf whose rows start at `rows` and hold n triangles.
  static Triangle triangle(const float* rows, std::uint32_t n, std::uint32_t i) {
    const auto at = [&](int k, int c) { return rows[(3 * k + c) * n + i]; };
    return {{at(0, 0), at(0, 1), at(0, 2)},
            {at(1, 0), at(1, 1), at(1, 2)},
            {at(2, 0), at(2, 1), at(2, 2)}};
  }

 private:
  HugePageVector<float> rows_;
};

// Tests the n triangles of a leaf (rows from KdLeafTriangles::leaf, primitive ids `ids`).
// Closest hit (kAnyHit false): updates `hit` under the tie rule of Hit with t in
// [tmin, hit.t]. Any hit: returns true as soon as a triangle is hit with t in [tmin, tmax].
template <bool kAnyHit>
inline bool intersect_leaf(const WatertightRay& r, const float* rows, const std::uint32_t* ids,
                           std::uint32_t n, float tmin, float tmax, Hit& hit) {
#if defined(__AVX2__)
  const int kx = r.kx, ky = r.ky, kz = r.kz;
  const __m256 ox = _mm256_set1_ps(r.org[kx]), oy = _mm256_set1_ps(r.org[ky]),
               oz = _mm256_set1_ps(r.org[kz]);
  const __m256 sx = _mm256_set1_ps(r.sx), sy = _mm256_set1_ps(r.sy), sz = _mm256_set1_ps(r.sz);
  const __m256 zero = _mm256_setzero_ps();
  const __m256 vtmin = _mm256_set1_ps(tmin);
  const std::size_t stride = n;
  for (std::uint32_t base = 0; base < n; base += 8) {
    const float* p = rows + base;
    const auto load = [&](int k, int c) { return _mm256_loadu_ps(p + (3 * k + c) * stride); };
    // Vertex k relative to the origin, sheared: the scalar test's ax, ay and a[kz].
    const __m256 az0 = _mm256_sub_ps(load(0, kz), oz);
    const __m256 bz0 = _mm256_sub_ps(load(1, kz), oz);
    const __m256 cz0 = _mm256_sub_ps(load(2, kz), oz);
    const __m256 ax = _mm256_sub_ps(_mm256_sub_ps(load(0, kx), ox), _mm256_mul_ps(sx, az0));
    const __m256 ay = _mm256_sub_ps(_mm256_sub_ps(load(0, ky), oy), _mm256_mul_ps(sy, az0));
    const __m256 bx = _mm256_sub_ps(_mm256_sub_ps(load(1, kx), ox), _mm256_mul_ps(sx, bz0));
    const __m256 by = _mm256_sub_ps(_mm256_sub_ps(load(1, ky), oy), _mm256_mul_ps(sy, bz0));
    const __m256 cx = _mm256_sub_ps(_mm256_sub_ps(load(2, kx), ox), _mm256_mul_ps(sx, cz0));
    const __m256 cy = _mm256_sub_ps(_mm256_sub_ps(load(2, ky), oy), _mm256_mul_ps(sy, cz0));
    const __m256 u = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
    const __m256 v = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
    const __m256 w = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
    const std::uint32_t lanes = n - base < 8 ? n - base : 8;
    const unsigned valid = (1u << lanes) - 1;

    const __m256 on_edge = _mm256_or_ps(
        _mm256_or_ps(_mm256_cmp_ps(u, zero, _CMP_EQ_OQ), _mm256_cmp_ps(v, zero, _CMP_EQ_OQ)),
        _mm256_cmp_ps(w, zero, _CMP_EQ_OQ));
    const unsigned edge = static_cast<unsigned>(_mm256_movemask_ps(on_edge)) & valid;
    const __m256 neg = _mm256_or_ps(
        _mm256_or_ps(_mm256_cmp_ps(u, zero, _CMP_LT_OQ), _mm256_cmp_ps(v, zero, _CMP_LT_OQ)),
        _mm256_cmp_ps(w, zero, _CMP_LT_OQ));
    const __m256 pos = _mm256_or_ps(
        _mm256_or_ps(_mm256_cmp_ps(u, zero, _CMP_GT_OQ), _mm256_cmp_ps(v, zero, _CMP_GT_OQ)),
        _mm256_cmp_ps(w, zero, _CMP_GT_OQ));
    const unsigned straddles = static_cast<unsigned>(_mm256_movemask_ps(_mm256_and_ps(neg, pos)));
    const unsigned inside = valid & ~edge & ~straddles;

    if (edge) {  // the scalar test decides these lanes (in double)
      for (unsigned m = edge; m; m &= m - 1) {
        const std::uint32_t i = base + static_cast<std::uint32_t>(__builtin_ctz(m));
        const Triangle tri = KdLeafTriangles::triangle(rows, n, i);
        if constexpr (kAnyHit) {
          float t, tu, tv;
          if (intersect_triangle(r, tri, tmin, tmax, t, tu, tv)) return true;
        } else {
          intersect_triangle(r, tri, ids[i], tmin, hit);
        }
      }
    }
    if (!inside) continue;

    const __m256 det = _mm256_add_ps(_mm256_add_ps(u, v), w);
    const __m256 t_scaled = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(u, _mm256_mul_ps(sz, az0)),
                                                        _mm256_mul_ps(v, _mm256_mul_ps(sz, bz0))),
                                          _mm256_mul_ps(w, _mm256_mul_ps(sz, cz0)));
    const __m256 inv_det = _mm256_div_ps(_mm256_set1_ps(1.0f), det);
    const __m256 t = _mm256_mul_ps(t_scaled, inv_det);
    const __m256 vtmax = _mm256_set1_ps(kAnyHit ? tmax : hit.t);
    const __m256 ok = _mm256_and_ps(
        _mm256_cmp_ps(det, zero, _CMP_NEQ_UQ),
        _mm256_and_ps(_mm256_cmp_ps(t, vtmin, _CMP_GE_OQ), _mm256_cmp_ps(t, vtmax, _CMP_LE_OQ)));
    unsigned accept = static_cast<unsigned>(_mm256_movemask_ps(ok)) & inside;
    if (!accept) continue;
    if constexpr (kAnyHit) return true;

    alignas(32) float ts[8], vs[8], ws[8], invs[8];
    _mm256_store_ps(ts, t);
    _mm256_store_ps(vs, v);
    _mm256_store_ps(ws, w);
    _mm256_store_ps(invs, inv_det);
    for (; accept; accept &= accept - 1) {
      const unsigned l = static_cast<unsigned>(__builtin_ctz(accept));
      Hit candidate;
      candidate.t = ts[l];
      candidate.prim = ids[base + l];
      if (!candidate.closer_than(hit)) continue;
      candidate.u = vs[l] * invs[l];
      candidate.v = ws[l] * invs[l];
      hit = candidate;
    }
  }
  return kAnyHit ? false : hit.found();
#else
  for (std::uint32_t i = 0; i < n; ++i) {
    const Triangle tri = KdLeafTriangles::triangle(rows, n, i);
    if constexpr (kAnyHit) {
      float t, tu, tv;
      if (intersect_triangle(r, tri, tmin, tmax, t, tu, tv)) return true;
    } else {
      intersect_triangle(r, tri, ids[i], tmin, hit);
    }
  }
  return kAnyHit ? false : hit.found();
#endif
}

}  // namespace splitray

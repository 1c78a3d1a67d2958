#pragma once
// One step of the wide kd walk: the ray's interval [t0, t1] clipped against the 7 planes of a
// wide node (kd_wide.hpp), giving each of its 8 cells the interval the binary tree's walk
// would give it. Level by level, the cell on the ray's first side of a plane gets
// min(t + pad, t1), the other max(t - pad, t0), with the plane's crossing t and margin pad of
// the split style of robust_ray.hpp (min and max are exact, so the order of levels is all
// that matters). Written twice with the same float operations: for AVX2 (all 8 cells in one
// pass) and portably; tests/kd_wide_clip_test.cpp checks that they agree bit for bit.
#include "splitray/accel/kd/kd_wide.hpp"
#include "splitray/core/simd.hpp"

namespace splitray {

struct KdCellClip {
  alignas(32) float t0[8], t1[8];  // each cell's interval
  unsigned enter;                  // occupied cells whose interval is not empty
  unsigned second[3];              // per level: the cells on the ray's second side of its plane
};

// The ray's origin, inverse direction and split margins per axis (RobustRay, Splits::pad).
inline KdCellClip clip_cells(const KdWideNode& node, const float org[3], const float inv[3],
                             const float pad[3], float t0, float t1) {
  KdCellClip out{};
  float hi[7], lo[7];
  bool negative[7];
  for (int p = 0; p < 7; ++p) {
    const int a = node.axis(p);
    const float t_split = (node.split[p] - org[a]) * inv[a];
    hi[p] = t_split + pad[a];
    lo[p] = t_split - pad[a];
    negative[p] = inv[a] < 0;
  }
  for (unsigned c = 0; c < 8; ++c) {
    float lower = t0, upper = t1;
    unsigned plane = 0;  // of level 0; then 1 + b0, then 3 + 2 b0 + b1 (cell c = b0 b1 b2)
    for (int level = 0; level < 3; ++level) {
      const unsigned above = (c >> (2 - level)) & 1u;
      const unsigned second = above ^ (negative[plane] ? 1u : 0u);
      if (second)
        lower = lo[plane] > lower ? lo[plane] : lower;
      else
        upper = hi[plane] < upper ? hi[plane] : upper;
      out.second[level] |= second << c;
      plane = 2 * plane + 1 + above;
    }
    out.t0[c] = lower;
    out.t1[c] = upper;
    if (lower <= upper) out.enter |= 1u << c;
  }
  out.enter &= node.occupied();
  return out;
}

#if defined(__AVX2__)
// The same for origin, inverse and margin in lanes 0-2 (lanes 3-7: any finite values).
inline KdCellClip clip_cells(const KdWideNode& node, simd::Float8 org, simd::Float8 inv,
                             simd::Float8 pad, float t0, float t1) {
  using simd::Float8;
  // Planes per cell at levels 1 and 2 (level 0: plane 0 everywhere), and the cells above
  // the plane of each level.
  const __m256i level0 = _mm256_setzero_si256();
  const __m256i level1 = _mm256_setr_epi32(1, 1, 1, 1, 2, 2, 2, 2);
  const __m256i level2 = _mm256_setr_epi32(3, 3, 4, 4, 5, 5, 6, 6);
  const __m256 above0 = _mm256_castsi256_ps(_mm256_setr_epi32(0, 0, 0, 0, -1, -1, -1, -1));
  const __m256 above1 = _mm256_castsi256_ps(_mm256_setr_epi32(0, 0, -1, -1, 0, 0, -1, -1));
  const __m256 above2 = _mm256_castsi256_ps(_mm256_setr_epi32(0, -1, 0, -1, 0, -1, 0, -1));
  const __m256i axis_shift = _mm256_setr_epi32(0, 2, 4, 6, 8, 10, 12, 0);

  const Float8 split = Float8::load(node.split);  // lane 7: meta, a normal float
  const __m256i axis = _mm256_and_si256(
      _mm256_srlv_epi32(_mm256_set1_epi32(static_cast<int>(node.meta)), axis_shift),
      _mm256_set1_epi32(3));
  const Float8 inv_p = permute(inv, axis), pad_p = permute(pad, axis);
  const Float8 t_split = (split - permute(org, axis)) * inv_p;
  const Float8 hi = t_split + pad_p, lo = t_split - pad_p;
  const simd::Mask8 negative = inv_p < Float8::zero();
  Float8 lower = Float8::broadcast(t0), upper = Float8::broadcast(t1);
  const auto clip = [&](__m256i planes, __m256 above) {
    const simd::Mask8 second{_mm256_xor_ps(above, _mm256_permutevar8x32_ps(negative.m, planes))};
    upper = select(second, upper, min(permute(hi, planes), upper));
    lower = select(second, max(permute(lo, planes), lower), lower);
    return second.bits();
  };
  KdCellClip out;
  out.second[0] = clip(level0, above0);
  out.second[1] = clip(level1, above1);
  out.second[2] = clip(level2, above2);
  out.enter = (lower <= upper).bits() & node.occupied();
  lower.store(out.t0);
  upper.store(out.t1);
  return out;
}
#endif

}  // namespace splitray

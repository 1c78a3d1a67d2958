#pragma once
// Thin wrappers over 8-lane (AVX) and 16-lane (AVX-512) float vectors, so that SIMD code reads
// like the scalar code it repeats lane by lane. Every operation is one instruction with the
// scalar operation's IEEE semantics, evaluated in the order written (the project builds with
// -ffp-contract=off: a * b + c stays two roundings), so code written with them gives the scalar
// code's bits. Two things differ from <cmath>/<algorithm>, as the instructions do:
// - min(a, b) is a < b ? a : b and max(a, b) is a > b ? a : b lane by lane: the second operand
//   when either is NaN (std::min(a, b) is min(b, a) here);
// - comparisons are C++'s: <, <=, >, >=, == are false with a NaN, != is true. They give a Mask,
//   combined with & and |, read as a bit per lane with bits().
// Float8 and __m256 convert into each other, so intrinsics without a wrapper mix in. Records
// copied in the hot loop (a traversal stack's entries) hold the plain vector (Float8::Vector):
// with the wrapper as their member, GCC 12 kept a walk's interval in memory (kd packets, -6%).
#if defined(__AVX__)
#include <immintrin.h>
#endif

namespace splitray::simd {

#if defined(__AVX__)

struct Mask8 {
  __m256 m;  // all bits of a lane set where the comparison holds
  unsigned bits() const { return static_cast<unsigned>(_mm256_movemask_ps(m)); }
};
inline Mask8 operator&(Mask8 a, Mask8 b) { return {_mm256_and_ps(a.m, b.m)}; }
inline Mask8 operator|(Mask8 a, Mask8 b) { return {_mm256_or_ps(a.m, b.m)}; }

struct Float8 {
  static constexpr int kLanes = 8;
  using Mask = Mask8;
  using Vector = __m256;
  Vector v;

  Float8() = default;
  Float8(__m256 x) : v(x) {}  // implicit both ways: intrinsics and wrappers mix
  operator __m256() const { return v; }

  static Float8 broadcast(float x) { return _mm256_set1_ps(x); }
  static Float8 zero() { return _mm256_setzero_ps(); }
  static Float8 load(const float* p) { return _mm256_load_ps(p); }  // 32-byte aligned
  static Float8 loadu(const float* p) { return _mm256_loadu_ps(p); }
  void store(float* p) const { _mm256_store_ps(p, v); }  // 32-byte aligned
  void storeu(float* p) const { _mm256_storeu_ps(p, v); }
};

inline Float8 operator+(Float8 a, Float8 b) { return _mm256_add_ps(a, b); }
inline Float8 operator-(Float8 a, Float8 b) { return _mm256_sub_ps(a, b); }
inline Float8 operator*(Float8 a, Float8 b) { return _mm256_mul_ps(a, b); }
inline Float8 operator/(Float8 a, Float8 b) { return _mm256_div_ps(a, b); }
inline Float8 min(Float8 a, Float8 b) { return _mm256_min_ps(a, b); }
inline Float8 max(Float8 a, Float8 b) { return _mm256_max_ps(a, b); }
inline Float8 abs(Float8 x) { return _mm256_andnot_ps(_mm256_set1_ps(-0.0f), x); }
// |magnitude| (non-negative) with the sign bit of `sign`.
inline Float8 with_sign(Float8 magnitude, Float8 sign) {
  return _mm256_or_ps(magnitude, _mm256_and_ps(_mm256_set1_ps(-0.0f), sign));
}
#if defined(__FMA__)
// a * b - c in one rounding (the fused instruction; -ffp-contract=off never makes one itself).
inline Float8 fmsub(Float8 a, Float8 b, Float8 c) { return _mm256_fmsub_ps(a, b, c); }
#endif
// Lane by lane mask ? yes : no.
inline Float8 select(Mask8 mask, Float8 yes, Float8 no) {
  return _mm256_blendv_ps(no, yes, mask.m);
}
inline Mask8 operator<(Float8 a, Float8 b) { return {_mm256_cmp_ps(a, b, _CMP_LT_OQ)}; }
inline Mask8 operator<=(Float8 a, Float8 b) { return {_mm256_cmp_ps(a, b, _CMP_LE_OQ)}; }
inline Mask8 operator>(Float8 a, Float8 b) { return {_mm256_cmp_ps(a, b, _CMP_GT_OQ)}; }
inline Mask8 operator>=(Float8 a, Float8 b) { return {_mm256_cmp_ps(a, b, _CMP_GE_OQ)}; }
inline Mask8 operator==(Float8 a, Float8 b) { return {_mm256_cmp_ps(a, b, _CMP_EQ_OQ)}; }
inline Mask8 operator!=(Float8 a, Float8 b) { return {_mm256_cmp_ps(a, b, _CMP_NEQ_UQ)}; }

#if defined(__AVX2__)
// Lane i of the result is lane index[i] (0-7) of `table`.
inline Float8 permute(Float8 table, __m256i index) {
  return _mm256_permutevar8x32_ps(table, index);
}
#endif

#endif  // __AVX__

#if defined(__AVX512F__)

struct Mask16 {
  __mmask16 m;
  unsigned bits() const { return m; }
};
inline Mask16 operator&(Mask16 a, Mask16 b) { return {static_cast<__mmask16>(a.m & b.m)}; }
inline Mask16 operator|(Mask16 a, Mask16 b) { return {static_cast<__mmask16>(a.m | b.m)}; }

struct Float16 {
  static constexpr int kLanes = 16;
  using Mask = Mask16;
  using Vector = __m512;
  Vector v;

  Float16() = default;
  Float16(__m512 x) : v(x) {}
  operator __m512() const { return v; }

  static Float16 broadcast(float x) { return _mm512_set1_ps(x); }
  static Float16 zero() { return _mm512_setzero_ps(); }
  static Float16 load(const float* p) { return _mm512_load_ps(p); }  // 64-byte aligned
  static Float16 loadu(const float* p) { return _mm512_loadu_ps(p); }
  void store(float* p) const { _mm512_store_ps(p, v); }  // 64-byte aligned
  void storeu(float* p) const { _mm512_storeu_ps(p, v); }
};

inline Float16 operator+(Float16 a, Float16 b) { return _mm512_add_ps(a, b); }
inline Float16 operator-(Float16 a, Float16 b) { return _mm512_sub_ps(a, b); }
inline Float16 operator*(Float16 a, Float16 b) { return _mm512_mul_ps(a, b); }
inline Float16 operator/(Float16 a, Float16 b) { return _mm512_div_ps(a, b); }
// The zero-masked forms (all lanes kept) avoid a false may-be-uninitialised warning of GCC 12's
// plain _mm512_min_ps / _mm512_max_ps.
inline Float16 min(Float16 a, Float16 b) { return _mm512_maskz_min_ps(0xffff, a, b); }
inline Float16 max(Float16 a, Float16 b) { return _mm512_maskz_max_ps(0xffff, a, b); }
inline Float16 abs(Float16 x) { return _mm512_abs_ps(x); }
// The least of the lanes in `m` (+inf when m is empty), halving the lanes four times
// (zero-masked extracts: the plain ones, and so the casts to 256 bits, trip the warning above).
inline float min_of(Float16 x, Mask16 m) {
  const __m512 v = _mm512_mask_blend_ps(m.m, _mm512_set1_ps(__builtin_inff()), x);
  const __m256 high = _mm256_castpd_ps(_mm512_maskz_extractf64x4_pd(0xff, _mm512_castps_pd(v), 1));
  const __m256 m8 = _mm256_min_ps(
      _mm256_castpd_ps(_mm512_maskz_extractf64x4_pd(0xff, _mm512_castps_pd(v), 0)), high);
  __m128 m4 = _mm_min_ps(_mm256_castps256_ps128(m8), _mm256_extractf128_ps(m8, 1));
  m4 = _mm_min_ps(m4, _mm_movehl_ps(m4, m4));
  m4 = _mm_min_ss(m4, _mm_shuffle_ps(m4, m4, 1));
  return _mm_cvtss_f32(m4);
}
inline Float16 with_sign(Float16 magnitude, Float16 sign) {
  const __m512i bit = _mm512_set1_epi32(static_cast<int>(0x80000000u));
  return _mm512_castsi512_ps(_mm512_or_si512(_mm512_castps_si512(magnitude),
                                             _mm512_and_si512(bit, _mm512_castps_si512(sign))));
}
inline Float16 fmsub(Float16 a, Float16 b, Float16 c) { return _mm512_fmsub_ps(a, b, c); }
inline Float16 select(Mask16 mask, Float16 yes, Float16 no) {
  return _mm512_mask_blend_ps(mask.m, no, yes);
}
inline Mask16 operator<(Float16 a, Float16 b) { return {_mm512_cmp_ps_mask(a, b, _CMP_LT_OQ)}; }
inline Mask16 operator<=(Float16 a, Float16 b) { return {_mm512_cmp_ps_mask(a, b, _CMP_LE_OQ)}; }
inline Mask16 operator>(Float16 a, Float16 b) { return {_mm512_cmp_ps_mask(a, b, _CMP_GT_OQ)}; }
inline Mask16 operator>=(Float16 a, Float16 b) { return {_mm512_cmp_ps_mask(a, b, _CMP_GE_OQ)}; }
inline Mask16 operator==(Float16 a, Float16 b) { return {_mm512_cmp_ps_mask(a, b, _CMP_EQ_OQ)}; }
inline Mask16 operator!=(Float16 a, Float16 b) { return {_mm512_cmp_ps_mask(a, b, _CMP_NEQ_UQ)}; }

#endif  // __AVX512F__

}  // namespace splitray::simd

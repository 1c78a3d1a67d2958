#include "splitray/core/coordinates.hpp"

#include <algorithm>
#include <cstddef>
#include <cstdio>

#if defined(__AVX512F__)
#include <immintrin.h>
#endif

#include "splitray/core/errors.hpp"
#include "splitray/core/triangle.hpp"

// The bounds behind the limits (triangle.hpp's intersect_triangle): differences vertex - origin
// are below 2^36 + 2^40 < 2^40.1; the shear factors |sx|, |sy| <= 1 give sheared coordinates
// below 2^41.1 and edge functions (two products) below 2^83.2; sz = 1 / d[kz] <= 2^2 gives
// scaled z below 2^42.1, so t_scaled (three products) stays below 2^126.9 < FLT_MAX.

namespace splitray {

namespace {

std::string limit_problem(const Vec3& p, float limit, const char* limit_text) {
  if (!is_finite(p)) return "a NaN or infinite coordinate";
  if (within(p, limit)) return {};
  const float worst = std::max({std::fabs(p.x), std::fabs(p.y), std::fabs(p.z)});
  char text[160];
  std::snprintf(text, sizeof text, "a coordinate of magnitude %g, beyond the limit %s",
                static_cast<double>(worst), limit_text);
  return text;
}

}  // namespace

std::string coordinate_problem(const Vec3& p) {
  return limit_problem(p, kMaxCoordinate, "+-2^36 (6.9e10) within which splitray traces exactly");
}

std::string origin_problem(const Vec3& p) {
  return limit_problem(p, kMaxRayOrigin, "+-2^40 (1.1e12) of ray origins");
}

bool all_as_given(std::span<const Ray> rays) {
  const auto as_given = [](const Ray& r) { return traceable(r) && direction_exponent(r) == 0; };
  std::size_t i = 0;
#if defined(__AVX512F__)
  static_assert(sizeof(Ray) == 8 * sizeof(float) && offsetof(Ray, tmax) == 7 * sizeof(float));
  // A vector holds two rays: lanes 0-2 and 8-10 the origins, 3-5 and 11-13 the directions, 6
  // and 14 tmin, 7 and 15 tmax. Ordered comparisons are false for NaN. (Zero-masked permute:
  // GCC 12 warns that the plain one's undefined source may be unset.)
  constexpr __mmask16 kOrigin = 0x0707, kDirection = 0x3838, kTmin = 0x4040;
  const __m512 origin_limit = _mm512_set1_ps(kMaxRayOrigin);
  const __m512 largest = _mm512_set1_ps(0x1p2f), least = _mm512_set1_ps(0x1p-2f);
  const __m512i tmax_lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 7, 7, 8, 9, 10, 11, 12, 13, 15, 15);
  for (; i + 2 <= rays.size(); i += 2) {
    const __m512 v = _mm512_loadu_ps(&rays[i].org.x);  // rays i and i + 1
    const __m512 magnitude = _mm512_abs_ps(v);
    const __mmask16 origin = _mm512_mask_cmp_ps_mask(kOrigin, magnitude, origin_limit, _CMP_LE_OQ);
    const __mmask16 bounded = _mm512_mask_cmp_ps_mask(kDirection, magnitude, largest, _CMP_LE_OQ);
    const __mmask16 large = _mm512_mask_cmp_ps_mask(kDirection, magnitude, least, _CMP_GE_OQ);
    const __mmask16 interval = _mm512_mask_cmp_ps_mask(
        kTmin, v, _mm512_maskz_permutexvar_ps(0xffff, tmax_lane, v), _CMP_LE_OQ);
    // Each ray: every origin coordinate within the limit, every direction component at most
    // 2^2 (not NaN) and one at least 2^-2, tmin <= tmax.
    if (origin != kOrigin || bounded != kDirection || interval != kTmin || (large & 0x0038) == 0 ||
        (large & 0x3800) == 0)
      return false;
  }
#endif
  return std::all_of(rays.begin() + static_cast<std::ptrdiff_t>(i), rays.end(), as_given);
}

void check_triangles(std::span<const Triangle> triangles, const std::string& where) {
  for (std::size_t i = 0; i < triangles.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (!within_coordinate_limit(triangles[i].vertex(k)))
        throw Error(where, "triangle " + std::to_string(i) + " has " +
                               coordinate_problem(triangles[i].vertex(k)));
}

}  // namespace splitray

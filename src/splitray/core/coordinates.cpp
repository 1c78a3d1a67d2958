#include "splitray/core/coordinates.hpp"

#include <algorithm>
#include <cstdio>

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

void check_triangles(std::span<const Triangle> triangles, const std::string& where) {
  for (std::size_t i = 0; i < triangles.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (!within_coordinate_limit(triangles[i].vertex(k)))
        throw Error(where, "triangle " + std::to_string(i) + " has " +
                               coordinate_problem(triangles[i].vertex(k)));
}

}  // namespace splitray

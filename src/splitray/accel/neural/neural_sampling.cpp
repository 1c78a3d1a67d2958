#include "splitray/accel/neural/neural_sampling.hpp"

#include <algorithm>
#include <cmath>

#include "splitray/core/random.hpp"

namespace splitray {

SurfaceSampler::SurfaceSampler(std::span<const Triangle> triangles) : triangles_(triangles) {
  cdf_.resize(triangles.size());
  double sum = 0;
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    const Triangle& t = triangles[i];
    const double a = 0.5 * static_cast<double>(length(cross(t.v1 - t.v0, t.v2 - t.v0)));
    if (std::isfinite(a)) sum += a;  // NaN triangles are never drawn
    cdf_[i] = sum;
  }
}

std::vector<Vec3> SurfaceSampler::sample(std::size_t count, std::uint64_t seed) const {
  std::vector<Vec3> out;
  if (triangles_.empty()) return out;
  out.reserve(count);
  Pcg32 rng(seed);
  const double total = cdf_.back();
  for (std::size_t k = 0; k < count; ++k) {
    std::size_t i;
    if (total > 0) {
      const double u = (static_cast<double>(rng.next_u32()) + 0.5) * 0x1p-32 * total;
      i = static_cast<std::size_t>(std::upper_bound(cdf_.begin(), cdf_.end(), u) - cdf_.begin());
      i = std::min(i, cdf_.size() - 1);
    } else {  // all triangles degenerate: their vertices are the surface
      i = rng.next_u32() % triangles_.size();
    }
    float s = rng.next_float(), t = rng.next_float();
    if (s + t > 1) {
      s = 1 - s;
      t = 1 - t;
    }
    const Triangle& tri = triangles_[i];
    out.push_back(tri.v0 + (tri.v1 - tri.v0) * s + (tri.v2 - tri.v0) * t);
  }
  return out;
}

std::vector<Vec3> sample_points(std::span<const Vec3> points, std::size_t count,
                                std::uint64_t seed) {
  if (points.size() <= count) return {points.begin(), points.end()};
  std::vector<Vec3> out;
  out.reserve(count);
  Pcg32 rng(seed);
  for (std::size_t k = 0; k < count; ++k) {
    const std::uint64_t r = (std::uint64_t{rng.next_u32()} << 32) | rng.next_u32();
    out.push_back(points[static_cast<std::size_t>(r % points.size())]);
  }
  return out;
}

}  // namespace splitray

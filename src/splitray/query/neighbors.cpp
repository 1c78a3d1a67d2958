#include "splitray/query/neighbors.hpp"

#include <cmath>
#include <string>

#include "splitray/core/errors.hpp"

namespace splitray {
namespace {

NeighborSummary summarize(std::span<const std::uint32_t> indices,
                          std::span<const float> distances) {
  NeighborSummary s;
  s.neighbors = indices.size();
  for (std::uint32_t i : indices) s.checksum += static_cast<std::uint64_t>(i) + 1;
  for (float d : distances) s.dist_sum += static_cast<double>(d);
  s.mean_dist = s.neighbors ? s.dist_sum / static_cast<double>(s.neighbors) : 0.0;
  return s;
}

}  // namespace

NeighborSummary summarize(const KnnResult& result) {
  return summarize(result.indices, result.distances);
}

NeighborSummary summarize(const RadiusResult& result) {
  return summarize(result.indices, result.distances);
}

void check_k(int k, std::size_t points, const char* where) {
  if (k < 1) throw Error(where, "k must be at least 1 (got " + std::to_string(k) + ")");
  if (static_cast<std::size_t>(k) > points)
    throw Error(where, "k = " + std::to_string(k) + " exceeds the number of points (" +
                           std::to_string(points) + ")");
}

void check_radius(float r, const char* where) {
  if (!(r >= 0) || !std::isfinite(r))
    throw Error(where, "the radius must be finite and >= 0 (got " + std::to_string(r) + ")");
}

void check_points(std::span<const Vec3> points, const char* where) {
  if (points.empty()) throw Error(where, "there are no points");
  if (points.size() >= (std::size_t{1} << 30))
    throw Error(where, std::to_string(points.size()) + " points exceed the limit of 2^30 - 1");
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!is_finite(points[i]))
      throw Error(where, "point " + std::to_string(i) + " has a NaN or infinite coordinate");
}

void check_queries(std::span<const Vec3> queries, const char* where) {
  for (std::size_t i = 0; i < queries.size(); ++i)
    if (!is_finite(queries[i]))
      throw Error(where, "query " + std::to_string(i) + " has a NaN or infinite coordinate");
}

}  // namespace splitray

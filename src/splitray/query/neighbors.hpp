#pragma once
// What every neighbour search returns, and the one definition of distance and order that makes
// answers of different structures comparable bit for bit:
//   distance²(p, q) = ((p.x - q.x)² + (p.y - q.y)²) + (p.z - q.z)²  in float, no FMA,
//   neighbours are ordered by (distance², index): ties go to the smaller index, so the k
//   nearest are unique; a radius search keeps every point with distance² <= r * r (float).
// Distances handed to users are Euclidean (sqrt of distance²), never squared.
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "splitray/core/vec.hpp"

namespace splitray {

inline float distance_squared(const Vec3& p, const Vec3& q) {
  const float dx = p.x - q.x, dy = p.y - q.y, dz = p.z - q.z;
  return (dx * dx + dy * dy) + dz * dz;
}

// k nearest neighbours of many queries, row-major: query q owns [q * k, q * k + k).
struct KnnResult {
  std::size_t queries = 0;
  int k = 0;
  std::vector<std::uint32_t> indices;  // nearest first
  std::vector<float> distances;

  std::span<const std::uint32_t> indices_of(std::size_t q) const {
    return {indices.data() + q * k, static_cast<std::size_t>(k)};
  }
  std::span<const float> distances_of(std::size_t q) const {
    return {distances.data() + q * k, static_cast<std::size_t>(k)};
  }
};

// All neighbours within a radius, compressed rows: query q owns [offsets[q], offsets[q + 1]).
struct RadiusResult {
  std::vector<std::uint64_t> offsets{0};
  std::vector<std::uint32_t> indices;  // per query sorted by (distance, index)
  std::vector<float> distances;

  std::size_t queries() const { return offsets.size() - 1; }
  std::span<const std::uint32_t> indices_of(std::size_t q) const {
    return {indices.data() + offsets[q], static_cast<std::size_t>(offsets[q + 1] - offsets[q])};
  }
  std::span<const float> distances_of(std::size_t q) const {
    return {distances.data() + offsets[q], static_cast<std::size_t>(offsets[q + 1] - offsets[q])};
  }
};

// The numbers `splitray knn --json` prints: checksum = sum of (index + 1) over all neighbours
// (equal across structures that agree, ties included), dist_sum = sum of distances in double
// (equal across structures even when they break ties differently).
struct NeighborSummary {
  std::uint64_t neighbors = 0;
  std::uint64_t checksum = 0;
  double dist_sum = 0;
  double mean_dist = 0;
};
NeighborSummary summarize(const KnnResult& result);
NeighborSummary summarize(const RadiusResult& result);

// Throws Error naming `where` unless 1 <= k <= points.
void check_k(int k, std::size_t points, const char* where);
// Throws Error naming `where` unless r is finite and >= 0.
void check_radius(float r, const char* where);
// Throws Error naming `where` if a point is NaN or infinite, or there are too many points.
void check_points(std::span<const Vec3> points, const char* where);
// Throws Error naming `where` if a query is NaN or infinite.
void check_queries(std::span<const Vec3> queries, const char* where);

}  // namespace splitray

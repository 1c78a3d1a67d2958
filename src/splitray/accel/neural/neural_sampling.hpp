#pragma once
// The M input points of the neural builder (paper 003 §4.1 "Input sampling"), reproducible
// from a seed for any thread count:
//  - triangles: area-weighted uniform samples of the surface. Drawing them needs the prefix
//    sums of the triangle areas (one O(N) pass, SurfaceSampler's constructor); each sample is
//    then O(log N). The network's inference that follows is independent of N.
//  - points: M of them drawn uniformly (with replacement), O(M); all of them when N <= M.
#include <cstdint>
#include <span>
#include <vector>

#include "splitray/core/triangle.hpp"

namespace splitray {

inline constexpr std::uint64_t kNeuralSampleSeed = 0x5eed0003;

class SurfaceSampler {
 public:
  explicit SurfaceSampler(std::span<const Triangle> triangles);  // the O(N) area prefix sums
  std::vector<Vec3> sample(std::size_t count, std::uint64_t seed = kNeuralSampleSeed) const;

 private:
  std::span<const Triangle> triangles_;
  std::vector<double> cdf_;  // inclusive prefix sums of the areas
};

std::vector<Vec3> sample_points(std::span<const Vec3> points, std::size_t count,
                                std::uint64_t seed = kNeuralSampleSeed);

}  // namespace splitray

#pragma once
// PCG32 (O'Neill 2014): small, fast and the same sequence on every platform, so that ray sets
// and samples are reproducible from a seed.
#include <cmath>
#include <cstdint>
#include <numbers>

#include "splitray/core/vec.hpp"

namespace splitray {

class Pcg32 {
 public:
  explicit Pcg32(std::uint64_t seed, std::uint64_t stream = 0x853c49e6748fea9bULL)
      : inc_((stream << 1u) | 1u) {
    next_u32();
    state_ += seed;
    next_u32();
  }
  std::uint32_t next_u32() {
    const std::uint64_t old = state_;
    state_ = old * 6364136223846793005ULL + inc_;
    const auto xorshifted = static_cast<std::uint32_t>(((old >> 18u) ^ old) >> 27u);
    const auto rot = static_cast<std::uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31u));
  }
  // Uniform in [0, 1).
  float next_float() { return static_cast<float>(next_u32() >> 8) * 0x1p-24f; }

 private:
  std::uint64_t state_ = 0x4d595df4d0f33173ULL;
  std::uint64_t inc_;
};

inline Vec3 uniform_sphere(float u1, float u2) {
  const float z = 1 - 2 * u1;
  const float r = std::sqrt(std::max(0.0f, 1 - z * z));
  const float phi = 2 * std::numbers::pi_v<float> * u2;
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// Cosine-distributed direction about unit normal n.
inline Vec3 cosine_hemisphere(const Vec3& n, float u1, float u2) {
  const float r = std::sqrt(u1), phi = 2 * std::numbers::pi_v<float> * u2;
  const Vec3 helper = std::fabs(n.x) > 0.9f ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
  const Vec3 t = normalize(cross(helper, n)), b = cross(n, t);
  return normalize(t * (r * std::cos(phi)) + b * (r * std::sin(phi)) + n * std::sqrt(std::max(0.0f, 1 - u1)));
}

}  // namespace splitray

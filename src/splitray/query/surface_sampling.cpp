#include "splitray/query/surface_sampling.hpp"

#include <algorithm>
#include <cmath>

#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/random.hpp"

namespace splitray {
namespace {

constexpr std::size_t kChunk = 65536;  // samples per generator: fixed, so threads don't matter

// 53 random bits in [0, 1): one float's 24 bits cannot pick among millions of triangles.
double next_double(Pcg32& rng) {
  const std::uint64_t hi = rng.next_u32() >> 5, lo = rng.next_u32() >> 6;
  return static_cast<double>((hi << 26) | lo) * 0x1p-53;
}

std::uint64_t mix(std::uint64_t x) {  // splitmix64 finaliser
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

}  // namespace

std::vector<Vec3> sample_surface(const Mesh& mesh, std::size_t count, std::uint64_t seed,
                                 std::uint64_t stream) {
  const std::string where = mesh.name.empty() ? std::string("surface sampling") : mesh.name;
  std::vector<double> cdf(mesh.faces.size());
  double total = 0;
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const double area = mesh.triangle(f).area();
    if (std::isfinite(area)) total += area;
    cdf[f] = total;
  }
  if (!(total > 0)) throw Error(where, "the mesh has no triangle of positive area to sample");
  std::vector<Vec3> samples(count);
  const std::size_t chunks = (count + kChunk - 1) / kChunk;
  parallel_chunks(chunks, 1, [&](std::size_t cb, std::size_t ce) {
    for (std::size_t c = cb; c < ce; ++c) {
      Pcg32 rng(seed, mix(stream * 0x100000000ULL + c));
      for (std::size_t i = c * kChunk; i < std::min(count, (c + 1) * kChunk); ++i) {
        const double x = next_double(rng) * total;
        const std::size_t f = std::min<std::size_t>(
            std::upper_bound(cdf.begin(), cdf.end(), x) - cdf.begin(), cdf.size() - 1);
        const Triangle t = mesh.triangle(f);
        // Uniform on the triangle: sqrt warps the first coordinate (Osada et al. 2002).
        const float su = std::sqrt(rng.next_float()), v = rng.next_float();
        const float b0 = 1 - su, b1 = v * su;
        samples[i] = t.v0 * b0 + t.v1 * b1 + t.v2 * (1 - b0 - b1);
      }
    }
  });
  return samples;
}

}  // namespace splitray

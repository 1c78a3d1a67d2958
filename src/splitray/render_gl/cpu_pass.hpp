#pragma once
// Pass 4 of the hybrid renderer: from the GPU's triangle ids, the CPU traces reflection and
// refraction rays (Whitted, as render/whitted.cpp) and exact shadow rays for boundary pixels.
#include <array>
#include <cstdint>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/core/image.hpp"
#include "splitray/core/scene.hpp"

namespace splitray::gl {

struct CpuPassInput {
  int width = 0, height = 0;
  Camera camera;
  std::vector<std::uint32_t> ids;                    // id + 1, top row first
  std::vector<std::array<float, 4>> mask;            // shadow-map visibility per light
  std::vector<std::array<std::uint8_t, 4>> boundary; // 1 = trace an exact shadow ray
};

struct CpuPassOutput {
  std::vector<std::array<float, 4>> color;     // rgb reflection + refraction, a unused
  std::vector<std::array<float, 4>> refined;   // visibility per light
  std::uint64_t rays = 0;
  std::size_t secondary_pixels = 0, boundary_pixels = 0;
  double ms = 0;
};

class CpuPass {
 public:
  CpuPass(const Scene& scene, const FlatScene& flat, const Accel& accel, int max_depth);
  void run(const CpuPassInput& in, bool secondary, bool refine, CpuPassOutput& out) const;

  // Exact visibility of light `i` from the primary hit of pixel (x, y) on triangle `prim`:
  // what whitted's shadow ray gives (transparent casters transmit), 0 where the surface faces
  // away from the light (whitted's shading skips the light there). For tests and the bench.
  float exact_visibility(const Camera& camera, int width, int height, int x, int y,
                         std::uint32_t prim, int light, std::uint64_t& rays) const;

 private:
  struct Surface;
  Surface surface(const Ray& ray, std::uint32_t prim, float t, float u, float v) const;
  Vec3 trace(const Ray& ray, int depth, std::uint64_t& rays) const;
  Vec3 shade(const Ray& ray, const Surface& s, int depth, std::uint64_t& rays) const;
  Vec3 secondary(const Ray& ray, const Surface& s, int depth, std::uint64_t& rays) const;
  float visibility(const Vec3& org, const Light& light, std::uint64_t& rays) const;

  const Scene& scene_;
  const FlatScene& flat_;
  const Accel& accel_;
  int max_depth_;
  float eps_;
  bool has_transparent_ = false;
};

}  // namespace splitray::gl

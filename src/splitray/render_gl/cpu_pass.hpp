#pragma once
// Pass 4 of the hybrid renderer: from the GPU's triangle ids, the CPU traces reflection and
// refraction rays and exact shadow rays for boundary pixels through the Whitted renderer's
// shading core (render/tracer.hpp); this file keeps the ID-buffer reconstruction of the
// primary hits and the pixel scheduling.
#include <array>
#include <cstdint>
#include <glm/glm.hpp>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/core/image.hpp"
#include "splitray/core/scene.hpp"
#include "splitray/render/tracer.hpp"

namespace splitray::gl {

// A light's shadow map of pass 1 read back for the CPU, so that the shadow rays of secondary
// hits are asked only where the map cannot answer: a 3x3 texel neighbourhood that agrees (all
// lit or all shadowed by opaque casters) answers, anything else (a shadow edge, a transparent
// caster, a point outside the map) traces the exact ray. The same test as pass 2 (normal
// offset, depth compare LEQUAL), conservative at edges as pass 3's blur is on screen.
struct LightMap {
  bool cube = false;
  int size = 0;
  std::array<glm::mat4, 6> matrices{};  // directional: [0]; cube faces in GL order
  Vec3 position{0};                     // point lights
  float range = 1, normal_offset = 0;
  std::vector<float> depth;        // faces x size x size, bottom row first (GL)
  std::vector<std::uint8_t> flag;  // transparent nearest caster

  // 1 lit, 0 shadowed, -1 ask a ray; `p` on a surface whose geometric normal `ng` faces the
  // ray that found it.
  int visibility(const Vec3& p, const Vec3& ng) const;
};

struct CpuPassInput {
  int width = 0, height = 0;
  Camera camera;
  std::vector<std::uint32_t> ids;                     // id + 1, top row first
  std::vector<std::array<float, 4>> mask;             // shadow-map visibility per light
  std::vector<std::array<std::uint8_t, 4>> boundary;  // 1 = trace an exact shadow ray
  std::vector<LightMap> maps;            // per light; empty: every secondary shadow ray is traced
  int x0 = 0, y0 = 0, x1 = -1, y1 = -1;  // the pixels to trace (x1, y1 < 0: to the edge)
};

struct CpuPassOutput {
  std::vector<std::array<float, 4>> color;    // rgb reflection + refraction, a unused
  std::vector<std::array<float, 4>> refined;  // visibility per light
  std::uint64_t rays = 0;
  std::uint64_t boundary_rays = 0;  // of `rays`: exact shadow rays of boundary pixels
  std::uint64_t map_answers = 0;    // secondary shadow rays the shadow maps made unnecessary
  std::size_t secondary_pixels = 0, boundary_pixels = 0;
  double ms = 0;
};

class CpuPass {
 public:
  // `lights`: the lights the frame is shaded with (the scene's, or fitted to the view).
  CpuPass(const Scene& scene, const FlatScene& flat, const std::vector<Light>& lights,
          const Accel& accel, int max_depth);
  void run(const CpuPassInput& in, bool secondary, bool refine, CpuPassOutput& out) const;

  // Exact visibility of light `i` from the primary hit of pixel (x, y) on triangle `prim`:
  // what whitted's shadow ray gives (transparent casters transmit), 0 where the surface faces
  // away from the light (whitted's shading skips the light there). For tests and the bench.
  float exact_visibility(const Camera& camera, int width, int height, int x, int y,
                         std::uint32_t prim, int light, std::uint64_t& rays) const;

 private:
  const FlatScene& flat_;
  WhittedTracer tracer_;  // the shading core, shared with the Whitted renderer
};

}  // namespace splitray::gl

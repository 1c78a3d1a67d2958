#pragma once
// The Whitted shading core (paper 002's CPU side), the one home of it: a hit prepared for
// shading (normals turned towards the ray, two-sided), Phong direct light with exact shadow
// rays through transparent casters, and reflection and refraction with Fresnel and total
// internal reflection. The Whitted renderer (whitted.cpp) traces camera rays with it; the
// hybrid renderer's CPU pass (render_gl/cpu_pass.cpp) shades the GPU's primary hits with it
// and answers shadow queries from its shadow maps where they can (ShadowAnswers), so that
// "the hybrid image equals the CPU image" holds by construction. Pure: a pixel depends only
// on its own rays.
#include <cstdint>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/core/scene.hpp"
#include "splitray/render/shading.hpp"

namespace splitray {

// Visibility of a light known without a ray (the hybrid renderer's shadow maps): 1 lit, 0
// shadowed, -1 unknown (trace the ray). `p` lies on a surface whose geometric normal `ng`
// faces the ray that found it.
class ShadowAnswers {
 public:
  virtual ~ShadowAnswers() = default;
  virtual int visibility(std::size_t light, const Vec3& p, const Vec3& ng) const = 0;
};

// A hit prepared for shading.
struct SurfacePoint {
  const Material* material = nullptr;
  Vec3 diffuse;          // the material's diffuse colour at the hit (textured)
  Vec3 d;                // unit ray direction
  Vec3 p;                // position from the barycentrics
  Vec3 ng, ns;           // geometric and shading normals, both facing the ray
  Vec3 n_bounce;         // the normal mirror and Snell use (ng where ns bends away from the viewer)
  bool entering = true;  // the ray came from the side the triangle's normal points to
};

// What one pixel's rays count, and where its shadow answers come from.
struct TraceCounters {
  std::uint64_t rays = 0;
  std::uint64_t map_answers = 0;           // shadow queries the answers made unnecessary
  const ShadowAnswers* answers = nullptr;  // null: every shadow ray is traced
};

class WhittedTracer {
 public:
  // `eps`: the offset of secondary rays off a surface (offset_epsilon of the scene).
  WhittedTracer(const Scene& scene, const FlatScene& flat, const std::vector<Light>& lights,
                const Accel& accel, int max_depth, float eps);

  // The colour a ray brings back from `depth` bounces on (background where it misses).
  Vec3 trace(const Ray& ray, int depth, TraceCounters& counters) const;
  // The hit of `ray` on triangle `prim` at barycentrics (u, v), prepared for shading.
  SurfacePoint surface(const Ray& ray, std::uint32_t prim, float u, float v) const;
  // Ambient + direct light (shadow rays or answers) + secondary().
  Vec3 shade(const SurfacePoint& s, int depth, TraceCounters& counters) const;
  // `color` plus the reflection and refraction of a hit at `depth` (nothing at the maximum
  // depth), added in that order.
  Vec3 secondary(const SurfacePoint& s, int depth, TraceCounters& counters,
                 Vec3 color = Vec3{0}) const;
  // Exact visibility of `light` from a hit: 0 where the surface faces away from it (shading
  // skips the light there), else the product of the transparencies of the surfaces between.
  float light_visibility(const SurfacePoint& s, const Light& light, std::uint64_t& rays) const;

  const std::vector<Light>& lights() const { return lights_; }

 private:
  float transmittance(const Vec3& org, const Light& light, const LightSample& sample,
                      std::uint64_t& rays) const;

  const Scene& scene_;
  const FlatScene& flat_;
  std::vector<Light> lights_;
  const Accel& accel_;
  int max_depth_;
  float eps_;
  bool has_transparent_ = false;
};

}  // namespace splitray

#pragma once
// The CPU reference renderer: Whitted ray tracing with Phong shading, shadow rays,
// reflection and refraction, tiles over all cores, the same image for every thread count.
#include <cstdint>
#include <functional>
#include <string>

#include "splitray/accel/accel.hpp"
#include "splitray/core/image.hpp"
#include "splitray/core/scene.hpp"
#include "splitray/render/view_lights.hpp"

namespace splitray {

struct RenderOptions {
  int width = 800;
  int height = 600;
  int max_depth = 5;     // reflection / refraction bounces
  std::string accel = "kd";
  BuildConfig build;     // build.threads also limits the render threads
  std::function<void(double done_fraction)> progress;  // called from one thread at a time
};

struct RenderResult {
  Image image;
  AccelStats accel_stats;
  double render_ms = 0;        // tracing and shading only, without the build
  std::uint64_t rays = 0;      // all rays cast: primary, shadow, secondary
  std::vector<Light> lights;   // the scene's, or those fitted to the view (lights_fit_view)
  LightCoverage coverage;      // whether the lights reach what the camera sees
  std::string gl_renderer;     // hybrid: the OpenGL renderer that ran (GL_RENDERER)
  double cpu_ms = 0;           // hybrid: the CPU pass's time (its rays are `rays`)
};

RenderResult render_whitted(const Scene& scene, const Camera& camera, const RenderOptions& options);

}  // namespace splitray

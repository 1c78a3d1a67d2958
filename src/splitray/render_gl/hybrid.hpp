#pragma once
// The hybrid GPU + CPU renderer of paper 002 in five passes: (1) shadow maps (LiSPSM for
// directional lights, cube maps for point lights), (2) triangle ids into an R32UI attachment
// plus the shadow-map test into a mask, (3) a KxK blur of the mask marking shadow
// boundaries, (4) on the CPU: reflection/refraction rays for pixels whose material needs them
// and exact shadow rays for boundary pixels, through any splitray structure, over all cores,
// (5) the Phong composite on the GPU adding the CPU's contribution.
// Interleaved: the GPU (the calling thread) works on frame n while a CPU pool works on
// frame n-1 (double-buffered camera and framebuffer state, one frame of latency).
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "splitray/render/whitted.hpp"

namespace splitray {

struct HybridOptions {
  int width = 800;
  int height = 600;
  int max_depth = 5;         // as RenderOptions::max_depth (primary hit = depth 0)
  std::string accel = "kd";  // the structure of the CPU pass
  BuildConfig build;
  int blur_kernel = 5;         // K of the KxK blur marking shadow boundaries (odd, >= 1)
  int shadow_map_size = 2048;  // texels per side (cube maps: per face, halved)
  bool lispsm = true;          // false: uniform (orthographic) shadow maps
  bool refine_shadows = true;  // exact shadow rays for boundary pixels
  bool secondary = true;       // reflection and refraction rays on the CPU
  // The shadow rays of secondary hits answered from the shadow maps where a 3x3 texel
  // neighbourhood agrees (traced at shadow edges, transparent casters and outside the maps).
  bool map_secondary_shadows = true;
  bool interleaved = true;  // false: the passes of each frame strictly in sequence
  // The CPU pass only for these pixels (a tile of an image split across ranks); the GPU passes
  // still see the whole frame, so the tile's pixels equal the whole frame's.
  std::optional<PixelRect> cpu_region;

  // The settings a Whitted render shares (size, depth, structure and its build).
  static HybridOptions from(const RenderOptions& render);
};

constexpr int kMaxHybridLights = 4;

// One finished frame and what it cost.
struct HybridFrame {
  Image image;
  std::array<double, 5> pass_ms{};  // GPU passes timed with queries, the CPU pass on the CPU
  std::uint64_t cpu_rays = 0;
  std::uint64_t boundary_rays = 0;   // of cpu_rays: exact shadow rays of boundary pixels; the
                                     // rest are secondary rays and their shadow rays
  std::uint64_t map_answers = 0;     // secondary shadow rays the shadow maps answered instead
  std::size_t secondary_pixels = 0;  // pixels whose material reflects or refracts
  std::size_t boundary_pixels = 0;   // pixels with a shadow boundary for any light
  // Debug buffers (top row first): triangle id + 1 (0 = background), the shadow-map's
  // visibility per light (0, 0.5 transparent caster, 1) and the refined visibility.
  std::vector<std::uint32_t> ids;
  std::vector<std::array<float, kMaxHybridLights>> mask, refined;
};

// Needs a current OpenGL 4.5 context on the calling thread for its whole life.
class HybridRenderer {
 public:
  // `view`: the camera that lights are fitted to when the scene has none (lights_fit_view).
  HybridRenderer(const Scene& scene, const HybridOptions& options, const Camera& view);
  ~HybridRenderer();

  // Renders the frames in order; `done` receives each finished frame (in order). With
  // options.interleaved the CPU pass of frame n overlaps the GPU passes of frame n+1.
  void render(std::span<const Camera> cameras, const std::function<void(HybridFrame&&)>& done);
  HybridFrame render_one(const Camera& camera);

  // Streaming use (the viewer): submit the next frame's camera; returns the frame finished
  // meanwhile (interleaved: the previous one, none for the first; sequential: this one).
  // finish() returns the frame still in flight. Change options only after finish().
  std::optional<HybridFrame> submit(const Camera& camera);
  std::optional<HybridFrame> finish();

  // Animation: frames submitted from now on show `triangles` (same count and order as the
  // scene's flattened triangles; flat-shaded), traced through the hierarchy `build` makes
  // from them (null: make_accel of the options). Frames in flight keep their own geometry.
  void set_triangles(
      std::vector<Triangle> triangles,
      const std::function<std::unique_ptr<Accel>(std::span<const Triangle>)>& build = {});

  // The composite of the last frame as a GL texture (RGBA32F), for the viewer.
  unsigned last_texture() const;
  const AccelStats& accel_stats() const;
  std::size_t light_count() const;
  const std::vector<Light>& lights() const;  // the lights frames are shaded with
  // Whether those lights reach what `camera` sees (render/view_lights.hpp).
  LightCoverage coverage(const Camera& camera) const;
  HybridOptions& options();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// One frame in a headless EGL context; RenderResult::rays counts the CPU's rays only, cpu_ms
// is the CPU pass's time and gl_renderer the OpenGL renderer that ran.
// Throws Error (never crashes) when no usable OpenGL 4.5 exists.
RenderResult render_hybrid(const Scene& scene, const Camera& camera, const HybridOptions& options);

}  // namespace splitray

#pragma once
// The CPU reference renderer: Whitted ray tracing with Phong shading, shadow rays,
// reflection and refraction, tiles over all cores, the same image for every thread count.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "splitray/accel/accel.hpp"
#include "splitray/core/image.hpp"
#include "splitray/core/scene.hpp"
#include "splitray/render/view_lights.hpp"

namespace splitray {

// Pixels [x0, x1) x [y0, y1) of an image.
struct PixelRect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  int width() const { return x1 - x0; }
  int height() const { return y1 - y0; }
  bool operator==(const PixelRect&) const = default;
};

struct RenderOptions {
  int width = 800;
  int height = 600;
  int max_depth = 5;  // reflection / refraction bounces
  std::string accel = "kd";
  BuildConfig build;  // build.threads also limits the render threads
  std::function<void(double done_fraction)> progress;  // called from one thread at a time
  // Only these pixels of the width x height image (a crop window), as an image of their size;
  // each pixel is the one of the full image.
  std::optional<PixelRect> crop;
};

struct RenderResult {
  Image image;
  AccelStats accel_stats;
  double render_ms = 0;       // tracing and shading only, without the build
  std::uint64_t rays = 0;     // all rays cast: primary, shadow, secondary
  std::vector<Light> lights;  // the scene's, or those fitted to the view (lights_fit_view)
  LightCoverage coverage;     // whether the lights reach what the camera sees
  std::string gl_renderer;    // hybrid: the OpenGL renderer that ran (GL_RENDERER)
  double cpu_ms = 0;          // hybrid: the CPU pass's time (its rays are `rays`)
};

RenderResult render_whitted(const Scene& scene, const Camera& camera, const RenderOptions& options);

// A scene prepared once (flattened, its structure built, its lights chosen for the full
// image) and then rendered region by region: the tiles of a distributed render. A region's
// pixels equal those of render_whitted's full image.
class WhittedRenderer {
 public:
  // Builds options.accel over the scene (options.build.threads threads).
  WhittedRenderer(const Scene& scene, const Camera& camera, const RenderOptions& options);
  // Uses `accel`, built by the caller over flatten(scene).triangles (same order).
  WhittedRenderer(const Scene& scene, const Camera& camera, const RenderOptions& options,
                  std::unique_ptr<Accel> accel);
  ~WhittedRenderer();
  WhittedRenderer(const WhittedRenderer&) = delete;
  WhittedRenderer& operator=(const WhittedRenderer&) = delete;

  // The pixels of `rect` (inside the image) as an image of its size; adds its rays to
  // `rays`. `progress` as RenderOptions::progress, over this region.
  Image render(const PixelRect& rect, std::uint64_t& rays,
               const std::function<void(double)>& progress = {}) const;

  const std::vector<Light>& lights() const;
  const LightCoverage& coverage() const;
  const AccelStats& accel_stats() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// The pixels of `rect` of a full image (renderers that draw the whole frame, then crop).
Image crop_image(const Image& full, const PixelRect& rect);

// The pixels of the crop window X0,X1,Y0,Y1 (fractions of the width and height, as pbrt's
// --cropwindow: pixels ceil(W x0) .. ceil(W x1) - 1), so that adjacent windows tile the
// image exactly. Error(`what`, ...) when a fraction is outside [0, 1], x0 >= x1 or y0 >= y1,
// or the window holds no pixel.
PixelRect crop_pixels(double x0, double x1, double y0, double y1, int width, int height,
                      const std::string& what = "--crop");

}  // namespace splitray

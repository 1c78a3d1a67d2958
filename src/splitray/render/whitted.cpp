#include "splitray/render/whitted.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <mutex>
#include <optional>
#include <vector>

#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/render/surface.hpp"
#include "splitray/render/tracer.hpp"

namespace splitray {

namespace {

constexpr int kTileSize = 16;
}  // namespace

struct WhittedRenderer::State {
  State(const Scene& scene_in, const Camera& camera_in, const RenderOptions& options_in,
        std::unique_ptr<Accel> accel_in)
      : scene(scene_in),
        camera(camera_in),
        options(options_in),
        flat(flatten(scene)),
        accel(accel_in ? std::move(accel_in)
                       : make_accel(options.accel, flat.triangles, options.build)) {
    lights = lights_for_view(scene, flat, *accel, camera, options.width, options.height);
    coverage = light_coverage(lights, flat, *accel, camera, options.width, options.height);
    tracer.emplace(scene, flat, lights, *accel, options.max_depth,
                   offset_epsilon(bounds_of(flat.triangles)));
    stats = accel->stats();
  }
  const Scene& scene;
  Camera camera;
  RenderOptions options;
  FlatScene flat;
  std::unique_ptr<Accel> accel;
  std::vector<Light> lights;
  LightCoverage coverage;
  AccelStats stats;
  std::optional<WhittedTracer> tracer;
};

namespace {

void check_options(const Scene& scene, const RenderOptions& options) {
  if (options.width <= 0 || options.height <= 0)
    throw Error("--size", "the image must be at least 1x1 pixels, got " +
                              std::to_string(options.width) + "x" + std::to_string(options.height));
  if (options.max_depth < 0)
    throw Error("--depth",
                "the bounce depth must be 0 or more, got " + std::to_string(options.max_depth));
  scene.validate("scene");
}

}  // namespace

WhittedRenderer::WhittedRenderer(const Scene& scene, const Camera& camera,
                                 const RenderOptions& options)
    : WhittedRenderer(scene, camera, options, nullptr) {}

WhittedRenderer::WhittedRenderer(const Scene& scene, const Camera& camera,
                                 const RenderOptions& options, std::unique_ptr<Accel> accel) {
  check_options(scene, options);
  const ThreadLimit limit(options.build.threads);
  state_ = std::make_unique<State>(scene, camera, options, std::move(accel));
}

WhittedRenderer::~WhittedRenderer() = default;

const std::vector<Light>& WhittedRenderer::lights() const { return state_->lights; }
const LightCoverage& WhittedRenderer::coverage() const { return state_->coverage; }
const AccelStats& WhittedRenderer::accel_stats() const { return state_->stats; }

Image WhittedRenderer::render(const PixelRect& rect, std::uint64_t& rays_out,
                              const std::function<void(double)>& progress) const {
  const RenderOptions& options = state_->options;
  if (rect.x0 < 0 || rect.y0 < 0 || rect.x1 > options.width || rect.y1 > options.height ||
      rect.width() <= 0 || rect.height() <= 0)
    throw Error("region", "pixels " + std::to_string(rect.x0) + ".." + std::to_string(rect.x1) +
                              " x " + std::to_string(rect.y0) + ".." + std::to_string(rect.y1) +
                              " are not inside the " + std::to_string(options.width) + "x" +
                              std::to_string(options.height) + " image");
  const ThreadLimit limit(options.build.threads);
  const WhittedTracer& tracer = *state_->tracer;
  const Camera& camera = state_->camera;
  Image image(rect.width(), rect.height());
  const int tiles_x = (rect.width() + kTileSize - 1) / kTileSize;
  const int tiles_y = (rect.height() + kTileSize - 1) / kTileSize;
  const auto tile_count = static_cast<std::size_t>(tiles_x) * tiles_y;
  std::vector<std::uint64_t> tile_rays(tile_count, 0);
  std::mutex progress_mutex;
  std::size_t tiles_done = 0;

  parallel_chunks(tile_count, 1, [&](std::size_t begin, std::size_t end) {
    for (std::size_t tile = begin; tile < end; ++tile) {
      const int x0 = rect.x0 + static_cast<int>(tile % tiles_x) * kTileSize;
      const int y0 = rect.y0 + static_cast<int>(tile / tiles_x) * kTileSize;
      const int x1 = std::min(x0 + kTileSize, rect.x1), y1 = std::min(y0 + kTileSize, rect.y1);
      TraceCounters counters;
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          const Ray ray =
              camera.generate(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f,
                              options.width, options.height);
          image.at(x - rect.x0, y - rect.y0) = tracer.trace(ray, 0, counters);
        }
      tile_rays[tile] = counters.rays;
      if (progress) {
        const std::lock_guard lock(progress_mutex);
        ++tiles_done;
        progress(static_cast<double>(tiles_done) / static_cast<double>(tile_count));
      }
    }
  });
  for (const std::uint64_t rays : tile_rays) rays_out += rays;  // tile order
  return image;
}

RenderResult render_whitted(const Scene& scene, const Camera& camera,
                            const RenderOptions& options) {
  const WhittedRenderer renderer(scene, camera, options);
  RenderResult result;
  result.lights = renderer.lights();
  result.coverage = renderer.coverage();
  result.accel_stats = renderer.accel_stats();
  const Timer timer;
  result.image =
      renderer.render(options.crop.value_or(PixelRect{0, 0, options.width, options.height}),
                      result.rays, options.progress);
  result.render_ms = timer.ms();
  return result;
}

PixelRect crop_pixels(double x0, double x1, double y0, double y1, int width, int height,
                      const std::string& what) {
  for (const double f : {x0, x1, y0, y1})
    if (!(f >= 0 && f <= 1))
      throw Error(what, "the fractions must lie in [0, 1], got " + std::to_string(f));
  if (!(x0 < x1) || !(y0 < y1)) throw Error(what, "the window needs X0 < X1 and Y0 < Y1");
  const auto at = [](double f, int size) { return static_cast<int>(std::ceil(f * size)); };
  const PixelRect rect{at(x0, width), at(y0, height), at(x1, width), at(y1, height)};
  if (rect.width() <= 0 || rect.height() <= 0)
    throw Error(what, "the window holds no pixel of the " + std::to_string(width) + "x" +
                          std::to_string(height) + " image");
  return rect;
}

Image crop_image(const Image& full, const PixelRect& rect) {
  Image part(rect.width(), rect.height());
  for (int y = 0; y < rect.height(); ++y)
    std::memcpy(&part.at(0, y), &full.at(rect.x0, rect.y0 + y),
                sizeof(Vec3) * static_cast<std::size_t>(rect.width()));
  return part;
}

}  // namespace splitray

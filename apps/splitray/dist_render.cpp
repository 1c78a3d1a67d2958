#include "dist_render.hpp"

#include <fmt/core.h>

#include <cstdint>
#include <cstring>
#include <functional>
#include <memory>
#include <optional>

#include "splitray/core/errors.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/dist/image_bytes.hpp"
#include "splitray/dist/world.hpp"
#if SPLITRAY_HAS_RENDER_GL
#include "splitray/render_gl/gl_context.hpp"
#include "splitray/render_gl/hybrid.hpp"
#endif

namespace splitray::app {

std::vector<PixelRect> tile_rects(const PixelRect& region, int tile_size) {
  if (tile_size < 1) throw Error("--tile-size", "must be at least 1");
  std::vector<PixelRect> tiles;
  for (int y = region.y0; y < region.y1; y += tile_size)
    for (int x = region.x0; x < region.x1; x += tile_size)
      tiles.push_back(
          {x, y, std::min(x + tile_size, region.x1), std::min(y + tile_size, region.y1)});
  return tiles;
}

namespace {

// What renders a tile on this rank: Whitted, or the hybrid renderer in a headless context.
struct TileRenderer {
  std::function<Image(const PixelRect&, std::uint64_t&)> render;
  std::vector<Light> lights;
  LightCoverage coverage;
  AccelStats accel_stats;
  std::shared_ptr<void> keep;  // the renderer (and context) behind `render`
};

TileRenderer whitted_tiles(const Scene& scene, const Camera& camera, const RenderOptions& options) {
  auto renderer = std::make_shared<WhittedRenderer>(scene, camera, options);
  TileRenderer t;
  t.render = [r = renderer.get()](const PixelRect& rect, std::uint64_t& rays) {
    return r->render(rect, rays);
  };
  t.lights = renderer->lights();
  t.coverage = renderer->coverage();
  t.accel_stats = renderer->accel_stats();
  t.keep = renderer;
  return t;
}

#if SPLITRAY_HAS_RENDER_GL
TileRenderer hybrid_tiles(const Scene& scene, const Camera& camera, const RenderOptions& options) {
  struct Hybrid {
    gl::EglContext context;
    std::optional<HybridRenderer> renderer;
  };
  auto h = std::make_shared<Hybrid>();
  HybridOptions hybrid = HybridOptions::from(options);
  hybrid.interleaved = false;  // one tile at a time
  h->renderer.emplace(scene, hybrid, camera);
  TileRenderer t;
  t.render = [h = h.get(), camera](const PixelRect& rect, std::uint64_t& rays) {
    h->renderer->options().cpu_region = rect;
    HybridFrame frame = h->renderer->render_one(camera);
    rays += frame.cpu_rays;
    return crop_image(frame.image, rect);
  };
  t.lights = h->renderer->lights();
  t.coverage = h->renderer->coverage(camera);
  t.accel_stats = h->renderer->accel_stats();
  t.keep = h;
  return t;
}
#endif

}  // namespace

DistRender render_distributed(const Scene& scene, const Camera& camera,
                              const RenderOptions& options, int tile_size,
                              const std::string& mode) {
  std::optional<TileRenderer> renderer;
  dist::all_or_none([&] {
#if SPLITRAY_HAS_RENDER_GL
    renderer.emplace(mode == "hybrid" ? hybrid_tiles(scene, camera, options)
                                      : whitted_tiles(scene, camera, options));
#else
    if (mode == "hybrid")
      throw Error("--mode hybrid", "this splitray was built without OpenGL (SPLITRAY_WITH_GL=OFF)");
    renderer.emplace(whitted_tiles(scene, camera, options));
#endif
  });
  const PixelRect region = options.crop.value_or(PixelRect{0, 0, options.width, options.height});
  std::vector<PixelRect> tiles;
  if (mode == "hybrid") {  // bands over the region's width: one GPU frame each
    for (int y = region.y0; y < region.y1; y += tile_size)
      tiles.push_back({region.x0, y, region.x1, std::min(y + tile_size, region.y1)});
  } else {
    tiles = tile_rects(region, tile_size);
  }

  DistRender out;
  out.tiles = tiles.size();
  RenderResult& result = out.result;
  result.lights = renderer->lights;
  result.coverage = renderer->coverage;
  result.accel_stats = renderer->accel_stats;
  if (dist::world().rank == 0) result.image = Image(region.width(), region.height());
  std::size_t collected = 0;

  dist::QueueOptions queue;
  queue.units = tiles.size();
  queue.name = [&](std::size_t unit) {
    const PixelRect& t = tiles[unit];
    return fmt::format("tile {} (pixels {}..{} x {}..{})", unit, t.x0, t.x1 - 1, t.y0, t.y1 - 1);
  };
  // A tile's bytes: its ray count, then its pixels.
  const auto work = [&](std::size_t unit) {
    std::uint64_t rays = 0;
    const Image image = renderer->render(tiles[unit], rays);
    std::string bytes(sizeof rays, '\0');
    std::memcpy(bytes.data(), &rays, sizeof rays);
    return bytes + dist::image_to_bytes(image);
  };
  const auto collect = [&](std::size_t unit, int, std::string&& bytes) {
    std::uint64_t rays = 0;
    if (bytes.size() < sizeof rays) throw Error("result of " + queue.name(unit), "too short");
    std::memcpy(&rays, bytes.data(), sizeof rays);
    const Image tile =
        dist::image_from_bytes(std::string_view(bytes).substr(sizeof rays), queue.name(unit));
    const PixelRect& t = tiles[unit];
    if (tile.width != t.width() || tile.height != t.height())
      throw Error("result of " + queue.name(unit), "has the wrong size");
    for (int y = 0; y < tile.height; ++y)
      std::memcpy(&result.image.at(t.x0 - region.x0, t.y0 - region.y0 + y), &tile.at(0, y),
                  sizeof(Vec3) * static_cast<std::size_t>(tile.width));
    result.rays += rays;
    if (options.progress) options.progress(static_cast<double>(++collected) / tiles.size());
  };
  const Timer timer;
  out.ranks = dist::run_queue(queue, work, collect);
  result.render_ms = timer.ms();
  return out;
}

}  // namespace splitray::app

#include "frame_renderer.hpp"

#include <fmt/core.h>

#include <filesystem>
#include <optional>

#include "splitray/core/errors.hpp"
#include "splitray/dist/world.hpp"
#include "splitray/render/whitted.hpp"
#if SPLITRAY_HAS_RENDER_GL
#include "splitray/render_gl/gl_context.hpp"
#include "splitray/render_gl/hybrid.hpp"
#endif

namespace splitray::app {

namespace {

namespace fs = std::filesystem;

// The triangles as the mesh's vertices, three per face (the frames' order).
Mesh& soup(const std::vector<Triangle>& triangles, Mesh& mesh) {
  mesh.positions.resize(triangles.size() * 3);
  mesh.faces.resize(triangles.size());
  for (std::size_t t = 0; t < triangles.size(); ++t) {
    const auto base = static_cast<std::uint32_t>(3 * t);
    for (int k = 0; k < 3; ++k) mesh.positions[base + k] = triangles[t].vertex(k);
    mesh.faces[t] = {base, base + 1, base + 2};
  }
  return mesh;
}

}  // namespace

#if SPLITRAY_HAS_RENDER_GL
struct FrameRenderer::Hybrid {
  gl::EglContext context;  // current on the thread that renders, for the renderer's life
  std::optional<HybridRenderer> renderer;
};
#else
struct FrameRenderer::Hybrid {};
#endif

FrameRenderer::FrameRenderer(FrameRenderer&&) noexcept = default;
FrameRenderer::~FrameRenderer() = default;

FrameRenderer::FrameRenderer(const FrameSequence& sequence, const std::vector<Triangle>& first,
                             FrameImageOptions options)
    : sequence_(sequence), options_(std::move(options)) {
  if (!enabled()) return;
  if (options_.mode != "whitted" && options_.mode != "hybrid")
    throw Error("--mode " + options_.mode, "frames render with whitted or hybrid");
#if !SPLITRAY_HAS_RENDER_GL
  if (options_.mode == "hybrid")
    throw Error("--mode hybrid", "this splitray was built without OpenGL (SPLITRAY_WITH_GL=OFF)");
#endif
  options_.build.builder.clear();
  if (auto aff = sequence.scene()) {
    scene_ = std::move(*aff);
  } else {
    Mesh mesh;
    mesh.name = "frame";
    scene_ = scene_from_mesh(soup(first, mesh));
  }
  fixed_camera_ = scene_.camera ? *scene_.camera : Camera::frame(scene_.bounds());
  if (dist::world().rank == 0) fs::create_directories(options_.dir);  // the one that writes
  if (scene_.lights_fit_view) {  // fitted to the first frame, kept for the others
    RenderOptions render;
    render.width = options_.width;
    render.height = options_.height;
    render.build = options_.build;
    const WhittedRenderer fit(scene(first), sequence_.camera(0).value_or(fixed_camera_), render);
    scene_.lights = fit.lights();
    scene_.lights_fit_view = false;
  }
}

std::string FrameRenderer::path(std::size_t frame) const {
  return (fs::path(options_.dir) / fmt::format("frame-{:04d}.png", frame)).string();
}

const Scene& FrameRenderer::scene(const std::vector<Triangle>& triangles) {
  soup(triangles, scene_.meshes[0]);
  triangles_ = triangles;
  return scene_;
}

Image FrameRenderer::image(std::size_t frame, std::unique_ptr<Accel> accel,
                           std::uint64_t& rays) const {
  if (options_.mode == "hybrid") return hybrid_image(frame, std::move(accel), rays);
  RenderOptions render;
  render.width = options_.width;
  render.height = options_.height;
  render.build = options_.build;
  const WhittedRenderer renderer(scene_, sequence_.camera(frame).value_or(fixed_camera_), render,
                                 std::move(accel));
  return renderer.render(PixelRect{0, 0, options_.width, options_.height}, rays);
}

// One hybrid renderer for all frames (its context and shaders are made once): each frame
// swaps in its triangles and the structure traced for them.
Image FrameRenderer::hybrid_image(std::size_t frame, std::unique_ptr<Accel> accel,
                                  std::uint64_t& rays) const {
#if SPLITRAY_HAS_RENDER_GL
  const Camera camera = sequence_.camera(frame).value_or(fixed_camera_);
  if (!hybrid_) {
    hybrid_ = std::make_unique<Hybrid>();
    HybridOptions options;
    options.width = options_.width;
    options.height = options_.height;
    options.max_depth = RenderOptions{}.max_depth;
    options.build = options_.build;
    options.interleaved = false;  // one frame at a time: each has its own structure
    hybrid_->renderer.emplace(scene_, options, camera);
  }
  // The caller's structure (built over these triangles, in this order), else the default.
  hybrid_->renderer->set_triangles(triangles_, [&](std::span<const Triangle> triangles) {
    return accel ? std::move(accel) : make_accel(RenderOptions{}.accel, triangles, options_.build);
  });
  HybridFrame picture = hybrid_->renderer->render_one(camera);
  rays += picture.cpu_rays;
  return std::move(picture.image);
#else
  (void)frame, (void)accel, (void)rays;
  throw Error("--mode hybrid", "this splitray was built without OpenGL (SPLITRAY_WITH_GL=OFF)");
#endif
}

void FrameRenderer::render(std::size_t frame, const std::vector<Triangle>& triangles) {
  if (!enabled()) return;
  scene(triangles);
  std::uint64_t rays = 0;
  const Image picture = image(frame, nullptr, rays);
  write_image(path(frame), picture);
}

}  // namespace splitray::app

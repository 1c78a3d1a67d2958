#include "splitray/render/whitted.hpp"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <optional>
#include <vector>

#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/render/shading.hpp"
#include "splitray/render/surface.hpp"

namespace splitray {

namespace {

constexpr int kTileSize = 16;
// A shadow ray crosses at most this many transparent surfaces before it counts as blocked.
constexpr int kMaxShadowCrossings = 16;

// Recursive Whitted tracing of one ray. Pure: a pixel depends only on its own rays, so the
// image is the same for every thread count and tile order.
class Tracer {
 public:
  Tracer(const Scene& scene, const FlatScene& flat, const std::vector<Light>& lights,
         const Accel& accel, int max_depth, float eps)
      : scene_(scene),
        flat_(flat),
        lights_(lights),
        accel_(accel),
        max_depth_(max_depth),
        eps_(eps) {
    for (const Material& m : flat.materials)
      has_transparent_ = has_transparent_ || m.transparency > 0;
  }

  Vec3 trace(const Ray& ray, int depth, std::uint64_t& rays) const {
    ++rays;
    const Hit hit = accel_.intersect(ray);
    if (!hit.found()) return scene_.background;
    return shade(ray, hit, depth, rays);
  }

 private:
  Vec3 shade(const Ray& ray, const Hit& hit, int depth, std::uint64_t& rays) const {
    const Triangle& tri = flat_.triangles[hit.prim];
    const Material& m = flat_.materials[flat_.material[hit.prim]];
    const Vec3 diffuse = m.diffuse_at(hit_uv(flat_.uvs[hit.prim], hit.u, hit.v));
    const Vec3 d = normalize(ray.dir);
    const Vec3 p = hit_position(tri, hit);

    // Two-sided: the geometric normal decides which side the ray came from (entering a
    // transparent object or leaving it); both normals are turned to face the ray.
    Vec3 ng = normalize(tri.geometric_normal());
    const bool entering = dot(ng, d) < 0;
    if (!entering) ng = -ng;
    const auto& vn = flat_.vertex_normals[hit.prim];
    Vec3 ns = normalize(vn[0] * (1 - hit.u - hit.v) + vn[1] * hit.u + vn[2] * hit.v);
    if (!(dot(ns, ns) > 0.5f) || !is_finite(ns)) ns = ng;
    if (dot(ns, ng) < 0) ns = -ns;
    // Where interpolation bends the normal away from the viewer, mirror and Snell use the
    // geometric normal instead.
    const Vec3 n_bounce = dot(d, ns) < 0 ? ns : ng;

    const Vec3 above = p + ng * eps_, below = p - ng * eps_;
    const float share = diffuse_share(m);
    Vec3 color = scene_.ambient * m.ambient.value_or(diffuse) * share;
    for (const Light& light : lights_) {
      const LightSample s = sample_light(light, p);
      if (dot(ng, s.to_light) <= 0) continue;  // the surface itself faces away
      const Vec3 c = phong(m, diffuse, share, ns, -d, s);
      if (c == Vec3{0}) continue;
      color += c * visibility(above, light, s, rays);
    }
    if (depth >= max_depth_) return color;

    float kr = m.reflectivity, kt = m.transparency;
    std::optional<Vec3> refracted;
    if (kt > 0) {
      const float n1 = entering ? 1.0f : m.ior, n2 = entering ? m.ior : 1.0f;
      refracted = refract(d, n_bounce, n1 / n2);
      if (refracted && dot(*refracted, ng) >= 0) refracted = refract(d, ng, n1 / n2);
      if (!refracted) {  // total internal reflection
        kr += kt;
        kt = 0;
      } else if (m.fresnel) {
        const float f = schlick(n1, n2, std::clamp(-dot(d, n_bounce), 0.0f, 1.0f),
                                std::clamp(-dot(*refracted, n_bounce), 0.0f, 1.0f));
        kr += kt * f;
        kt *= 1 - f;
      }
    }
    if (kr > 0) {
      Vec3 r = reflect(d, n_bounce);
      if (dot(r, ng) <= 0) r = reflect(d, ng);
      color += trace(Ray{above, r}, depth + 1, rays) * kr;
    }
    if (kt > 0) color += trace(Ray{below, *refracted}, depth + 1, rays) * kt;
    return color;
  }

  // 1 if the light is visible from `org`, 0 if an opaque surface blocks it, and the product
  // of the transparencies of the transparent surfaces in between otherwise (hard shadows
  // lightened by glass; no caustics).
  Vec3 visibility(const Vec3& org, const Light& light, const LightSample& s,
                  std::uint64_t& rays) const {
    Ray ray{org, s.to_light, 0, s.distance};
    ++rays;
    if (!accel_.occluded(ray)) return Vec3{1};
    if (!has_transparent_) return Vec3{0};
    float transmitted = 1;
    for (int crossing = 0; crossing < kMaxShadowCrossings; ++crossing) {
      ++rays;
      const Hit hit = accel_.intersect(ray);
      if (!hit.found()) return Vec3{transmitted};
      const Material& m = flat_.materials[flat_.material[hit.prim]];
      if (m.transparency <= 0) return Vec3{0};
      transmitted *= m.transparency;
      const Triangle& tri = flat_.triangles[hit.prim];
      Vec3 ng = normalize(tri.geometric_normal());
      if (dot(ng, ray.dir) < 0) ng = -ng;  // continue on the far side
      ray.org = hit_position(tri, hit) + ng * eps_;
      const LightSample next = sample_light(light, ray.org);
      ray.dir = next.to_light;
      ray.tmax = next.distance;
    }
    return Vec3{0};
  }

  const Scene& scene_;
  const FlatScene& flat_;
  const std::vector<Light>& lights_;
  const Accel& accel_;
  int max_depth_;
  float eps_;
  bool has_transparent_ = false;
};

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
  std::optional<Tracer> tracer;
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
  const Tracer& tracer = *state_->tracer;
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
      std::uint64_t rays = 0;
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          const Ray ray =
              camera.generate(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f,
                              options.width, options.height);
          image.at(x - rect.x0, y - rect.y0) = tracer.trace(ray, 0, rays);
        }
      tile_rays[tile] = rays;
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

}  // namespace splitray

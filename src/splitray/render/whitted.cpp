#include "splitray/render/whitted.hpp"

#include <algorithm>
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

RenderResult render_whitted(const Scene& scene, const Camera& camera,
                            const RenderOptions& options) {
  if (options.width <= 0 || options.height <= 0)
    throw Error("--size", "the image must be at least 1x1 pixels, got " +
                              std::to_string(options.width) + "x" + std::to_string(options.height));
  if (options.max_depth < 0)
    throw Error("--depth",
                "the bounce depth must be 0 or more, got " + std::to_string(options.max_depth));
  scene.validate("scene");

  ThreadLimit limit(options.build.threads);
  const FlatScene flat = flatten(scene);
  const auto accel = make_accel(options.accel, flat.triangles, options.build);
  RenderResult result;
  result.lights = lights_for_view(scene, flat, *accel, camera, options.width, options.height);
  result.coverage =
      light_coverage(result.lights, flat, *accel, camera, options.width, options.height);
  const Tracer tracer(scene, flat, result.lights, *accel, options.max_depth,
                      offset_epsilon(bounds_of(flat.triangles)));
  result.accel_stats = accel->stats();
  result.image = Image(options.width, options.height);
  const int tiles_x = (options.width + kTileSize - 1) / kTileSize;
  const int tiles_y = (options.height + kTileSize - 1) / kTileSize;
  const auto tile_count = static_cast<std::size_t>(tiles_x) * tiles_y;
  std::vector<std::uint64_t> tile_rays(tile_count, 0);
  std::mutex progress_mutex;
  std::size_t tiles_done = 0;

  const Timer timer;
  parallel_chunks(tile_count, 1, [&](std::size_t begin, std::size_t end) {
    for (std::size_t tile = begin; tile < end; ++tile) {
      const int x0 = static_cast<int>(tile % tiles_x) * kTileSize;
      const int y0 = static_cast<int>(tile / tiles_x) * kTileSize;
      const int x1 = std::min(x0 + kTileSize, options.width),
                y1 = std::min(y0 + kTileSize, options.height);
      std::uint64_t rays = 0;
      for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) {
          const Ray ray =
              camera.generate(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f,
                              options.width, options.height);
          result.image.at(x, y) = tracer.trace(ray, 0, rays);
        }
      tile_rays[tile] = rays;
      if (options.progress) {
        const std::lock_guard lock(progress_mutex);
        ++tiles_done;
        options.progress(static_cast<double>(tiles_done) / static_cast<double>(tile_count));
      }
    }
  });
  result.render_ms = timer.ms();
  for (const std::uint64_t rays : tile_rays) result.rays += rays;  // tile order
  return result;
}

}  // namespace splitray

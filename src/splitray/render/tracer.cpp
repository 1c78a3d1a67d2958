#include "splitray/render/tracer.hpp"

#include <algorithm>
#include <optional>

#include "splitray/render/surface.hpp"

namespace splitray {

namespace {

// A shadow ray crosses at most this many transparent surfaces before it counts as blocked.
constexpr int kMaxShadowCrossings = 16;

}  // namespace

WhittedTracer::WhittedTracer(const Scene& scene, const FlatScene& flat,
                             const std::vector<Light>& lights, const Accel& accel, int max_depth,
                             float eps)
    : scene_(scene), flat_(flat), lights_(lights), accel_(accel), max_depth_(max_depth), eps_(eps) {
  for (const Material& m : flat.materials)
    has_transparent_ = has_transparent_ || m.transparency > 0;
}

Vec3 WhittedTracer::trace(const Ray& ray, int depth, TraceCounters& counters) const {
  ++counters.rays;
  const Hit hit = accel_.intersect(ray);
  if (!hit.found()) return scene_.background;
  return shade(surface(ray, hit.prim, hit.u, hit.v), depth, counters);
}

SurfacePoint WhittedTracer::surface(const Ray& ray, std::uint32_t prim, float u, float v) const {
  const Triangle& tri = flat_.triangles[prim];
  SurfacePoint s;
  s.material = &flat_.materials[flat_.material[prim]];
  s.diffuse = s.material->diffuse_at(hit_uv(flat_.uvs[prim], u, v));
  s.d = normalize(ray.dir);
  Hit hit;
  hit.u = u;
  hit.v = v;
  s.p = hit_position(tri, hit);
  // Two-sided: the geometric normal decides which side the ray came from (entering a
  // transparent object or leaving it); both normals are turned to face the ray.
  s.ng = normalize(tri.geometric_normal());
  s.entering = dot(s.ng, s.d) < 0;
  if (!s.entering) s.ng = -s.ng;
  const auto& vn = flat_.vertex_normals[prim];
  s.ns = normalize(vn[0] * (1 - u - v) + vn[1] * u + vn[2] * v);
  if (!(dot(s.ns, s.ns) > 0.5f) || !is_finite(s.ns)) s.ns = s.ng;
  if (dot(s.ns, s.ng) < 0) s.ns = -s.ns;
  // Where interpolation bends the normal away from the viewer, mirror and Snell use the
  // geometric normal instead.
  s.n_bounce = dot(s.d, s.ns) < 0 ? s.ns : s.ng;
  return s;
}

Vec3 WhittedTracer::shade(const SurfacePoint& s, int depth, TraceCounters& counters) const {
  const Material& m = *s.material;
  const float share = diffuse_share(m);
  Vec3 color = scene_.ambient * m.ambient.value_or(s.diffuse) * share;
  const Vec3 above = s.p + s.ng * eps_;
  for (std::size_t i = 0; i < lights_.size(); ++i) {
    const Light& light = lights_[i];
    const LightSample sample = sample_light(light, s.p);
    if (dot(s.ng, sample.to_light) <= 0) continue;  // the surface itself faces away
    const Vec3 c = phong(m, s.diffuse, share, s.ns, -s.d, sample);
    if (c == Vec3{0}) continue;
    const int known = counters.answers ? counters.answers->visibility(i, s.p, s.ng) : -1;
    if (known >= 0) ++counters.map_answers;
    color += c * (known >= 0 ? static_cast<float>(known)
                             : transmittance(above, light, sample, counters.rays));
  }
  return secondary(s, depth, counters, color);
}

Vec3 WhittedTracer::secondary(const SurfacePoint& s, int depth, TraceCounters& counters,
                              Vec3 color) const {
  if (depth >= max_depth_) return color;
  const Material& m = *s.material;
  float kr = m.reflectivity, kt = m.transparency;
  std::optional<Vec3> refracted;
  if (kt > 0) {
    const float n1 = s.entering ? 1.0f : m.ior, n2 = s.entering ? m.ior : 1.0f;
    refracted = refract(s.d, s.n_bounce, n1 / n2);
    if (refracted && dot(*refracted, s.ng) >= 0) refracted = refract(s.d, s.ng, n1 / n2);
    if (!refracted) {  // total internal reflection
      kr += kt;
      kt = 0;
    } else if (m.fresnel) {
      const float f = schlick(n1, n2, std::clamp(-dot(s.d, s.n_bounce), 0.0f, 1.0f),
                              std::clamp(-dot(*refracted, s.n_bounce), 0.0f, 1.0f));
      kr += kt * f;
      kt *= 1 - f;
    }
  }
  if (kr > 0) {
    Vec3 r = reflect(s.d, s.n_bounce);
    if (dot(r, s.ng) <= 0) r = reflect(s.d, s.ng);
    color += trace(Ray{s.p + s.ng * eps_, r}, depth + 1, counters) * kr;
  }
  if (kt > 0) color += trace(Ray{s.p - s.ng * eps_, *refracted}, depth + 1, counters) * kt;
  return color;
}

float WhittedTracer::light_visibility(const SurfacePoint& s, const Light& light,
                                      std::uint64_t& rays) const {
  const LightSample sample = sample_light(light, s.p);
  if (dot(s.ng, sample.to_light) <= 0) return 0;
  return transmittance(s.p + s.ng * eps_, light, sample, rays);
}

// 1 if the light is visible from `org`, 0 if an opaque surface blocks it, and the product of
// the transparencies of the transparent surfaces in between otherwise (hard shadows lightened
// by glass; no caustics). `sample`: the light seen from the surface point `org` lies above.
float WhittedTracer::transmittance(const Vec3& org, const Light& light, const LightSample& sample,
                                   std::uint64_t& rays) const {
  Ray ray{org, sample.to_light, 0, sample.distance};
  ++rays;
  if (!accel_.occluded(ray)) return 1;
  if (!has_transparent_) return 0;
  float transmitted = 1;
  for (int crossing = 0; crossing < kMaxShadowCrossings; ++crossing) {
    ++rays;
    const Hit hit = accel_.intersect(ray);
    if (!hit.found()) return transmitted;
    const Material& m = flat_.materials[flat_.material[hit.prim]];
    if (m.transparency <= 0) return 0;
    transmitted *= m.transparency;
    const Triangle& tri = flat_.triangles[hit.prim];
    Vec3 ng = normalize(tri.geometric_normal());
    if (dot(ng, ray.dir) < 0) ng = -ng;  // continue on the far side
    ray.org = hit_position(tri, hit) + ng * eps_;
    const LightSample next = sample_light(light, ray.org);
    ray.dir = next.to_light;
    ray.tmax = next.distance;
  }
  return 0;
}

}  // namespace splitray

#include "splitray/render_gl/cpu_pass.hpp"

#include <cmath>
#include <algorithm>
#include <optional>

#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/render/shading.hpp"
#include "splitray/render/surface.hpp"

namespace splitray::gl {

namespace {
constexpr int kMaxShadowCrossings = 16;  // as whitted.cpp
constexpr std::size_t kRowsPerChunk = 4;
}  // namespace

// A hit prepared for shading: position, normals turned towards the ray, side.
struct CpuPass::Surface {
  const Material* m;
  Vec3 diffuse;  // the material's diffuse colour at the hit (textured)
  Vec3 d, p, ng, ns, n_bounce;
  bool entering;
};

CpuPass::CpuPass(const Scene& scene, const FlatScene& flat, const std::vector<Light>& lights,
                 const Accel& accel, int max_depth)
    : scene_(scene), flat_(flat), lights_(lights), accel_(accel), max_depth_(max_depth),
      eps_(offset_epsilon(bounds_of(flat.triangles))) {
  for (const Material& m : flat.materials) has_transparent_ = has_transparent_ || m.transparency > 0;
}

CpuPass::Surface CpuPass::surface(const Ray& ray, std::uint32_t prim, float t, float u,
                                  float v) const {
  (void)t;
  const Triangle& tri = flat_.triangles[prim];
  Surface s;
  s.m = &flat_.materials[flat_.material[prim]];
  s.diffuse = s.m->diffuse_at(hit_uv(flat_.uvs[prim], u, v));
  s.d = normalize(ray.dir);
  Hit hit;
  hit.u = u;
  hit.v = v;
  s.p = hit_position(tri, hit);
  s.ng = normalize(tri.geometric_normal());
  s.entering = dot(s.ng, s.d) < 0;
  if (!s.entering) s.ng = -s.ng;
  const auto& vn = flat_.vertex_normals[prim];
  s.ns = normalize(vn[0] * (1 - u - v) + vn[1] * u + vn[2] * v);
  if (!(dot(s.ns, s.ns) > 0.5f) || !is_finite(s.ns)) s.ns = s.ng;
  if (dot(s.ns, s.ng) < 0) s.ns = -s.ns;
  s.n_bounce = dot(s.d, s.ns) < 0 ? s.ns : s.ng;
  return s;
}

int LightMap::visibility(const Vec3& p, const Vec3& ng) const {
  const Vec3 q = p + ng * normal_offset;
  int face = 0;
  float reference = 0;
  if (cube) {
    const Vec3 d = q - position;
    const Vec3 a{std::abs(d.x), std::abs(d.y), std::abs(d.z)};
    const int axis = a.x >= a.y && a.x >= a.z ? 0 : (a.y >= a.z ? 1 : 2);
    face = 2 * axis + (d[axis] < 0 ? 1 : 0);
    reference = length(d) / range;
  }
  const glm::vec4 c = matrices[face] * glm::vec4(q.x, q.y, q.z, 1.0f);
  if (!(c.w > 0)) return -1;
  const float sx = c.x / c.w * 0.5f + 0.5f, sy = c.y / c.w * 0.5f + 0.5f;
  if (!cube) reference = c.z / c.w * 0.5f + 0.5f;
  if (!(reference >= 0 && reference <= 1)) return -1;
  const float fx = sx * static_cast<float>(size), fy = sy * static_cast<float>(size);
  if (!(fx >= 1 && fy >= 1 && fx < static_cast<float>(size - 1) && fy < static_cast<float>(size - 1)))
    return -1;
  const int tx = static_cast<int>(fx), ty = static_cast<int>(fy);
  int lit = 0;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx) {
      const std::size_t i = (static_cast<std::size_t>(face) * size + (ty + dy)) * size + (tx + dx);
      if (flag[i]) return -1;
      lit += reference <= depth[i];
    }
  return lit == 9 ? 1 : (lit == 0 ? 0 : -1);
}

Vec3 CpuPass::trace(const Ray& ray, int depth, Trace& t) const {
  ++t.rays;
  const Hit hit = accel_.intersect(ray);
  if (!hit.found()) return scene_.background;
  return shade(ray, surface(ray, hit.prim, hit.t, hit.u, hit.v), depth, t);
}

Vec3 CpuPass::shade(const Ray& ray, const Surface& s, int depth, Trace& t) const {
  const Material& m = *s.m;
  const float share = diffuse_share(m);
  Vec3 color = scene_.ambient * m.ambient.value_or(s.diffuse) * share;
  for (std::size_t i = 0; i < lights_.size(); ++i) {
    const Light& light = lights_[i];
    const LightSample ls = sample_light(light, s.p);
    if (dot(s.ng, ls.to_light) <= 0) continue;
    const Vec3 c = phong(m, s.diffuse, share, s.ns, -s.d, ls);
    if (c == Vec3{0}) continue;
    const int answer = t.maps && i < t.maps->size() ? (*t.maps)[i].visibility(s.p, s.ng) : -1;
    if (answer >= 0) ++t.map_answers;
    color += c * (answer >= 0 ? static_cast<float>(answer) : visibility(s.p + s.ng * eps_, light, t.rays));
  }
  return color + secondary(ray, s, depth, t);
}

// Reflection and refraction of a surface hit at `depth` (whitted.cpp's rules).
Vec3 CpuPass::secondary(const Ray& ray, const Surface& s, int depth, Trace& t) const {
  (void)ray;
  if (depth >= max_depth_) return Vec3{0};
  const Material& m = *s.m;
  float kr = m.reflectivity, kt = m.transparency;
  std::optional<Vec3> refracted;
  if (kt > 0) {
    const float n1 = s.entering ? 1.0f : m.ior, n2 = s.entering ? m.ior : 1.0f;
    refracted = refract(s.d, s.n_bounce, n1 / n2);
    if (refracted && dot(*refracted, s.ng) >= 0) refracted = refract(s.d, s.ng, n1 / n2);
    if (!refracted) {
      kr += kt;
      kt = 0;
    } else if (m.fresnel) {
      const float f = schlick(n1, n2, std::clamp(-dot(s.d, s.n_bounce), 0.0f, 1.0f),
                              std::clamp(-dot(*refracted, s.n_bounce), 0.0f, 1.0f));
      kr += kt * f;
      kt *= 1 - f;
    }
  }
  Vec3 color{0};
  if (kr > 0) {
    Vec3 r = reflect(s.d, s.n_bounce);
    if (dot(r, s.ng) <= 0) r = reflect(s.d, s.ng);
    color += trace(Ray{s.p + s.ng * eps_, r}, depth + 1, t) * kr;
  }
  if (kt > 0) color += trace(Ray{s.p - s.ng * eps_, *refracted}, depth + 1, t) * kt;
  return color;
}

float CpuPass::visibility(const Vec3& org, const Light& light, std::uint64_t& rays) const {
  const LightSample s = sample_light(light, org);
  Ray ray{org, s.to_light, 0, s.distance};
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
    if (dot(ng, ray.dir) < 0) ng = -ng;
    ray.org = hit_position(tri, hit) + ng * eps_;
    const LightSample next = sample_light(light, ray.org);
    ray.dir = next.to_light;
    ray.tmax = next.distance;
  }
  return 0;
}

namespace {

// The camera ray's hit on the plane of triangle `tri`: t and barycentrics (u of v1, v of v2).
bool plane_hit(const Ray& ray, const Triangle& tri, float& t, float& u, float& v) {
  const Vec3 e1 = tri.v1 - tri.v0, e2 = tri.v2 - tri.v0;
  const Vec3 pv = cross(ray.dir, e2);
  const float det = dot(e1, pv);
  if (det == 0) return false;
  const float inv = 1 / det;
  const Vec3 tv = ray.org - tri.v0;
  u = dot(tv, pv) * inv;
  const Vec3 qv = cross(tv, e1);
  v = dot(ray.dir, qv) * inv;
  t = dot(e2, qv) * inv;
  // Pixel centres just outside the triangle (rasteriser vs ray at edges): clamp into it.
  u = std::clamp(u, 0.0f, 1.0f);
  v = std::clamp(v, 0.0f, 1.0f - u);
  return true;
}

}  // namespace

float CpuPass::exact_visibility(const Camera& camera, int width, int height, int x, int y,
                                std::uint32_t prim, int light, std::uint64_t& rays) const {
  const Ray ray = camera.generate(x + 0.5f, y + 0.5f, width, height);
  float t, u, v;
  if (!plane_hit(ray, flat_.triangles[prim], t, u, v)) return 1;
  const Surface s = surface(ray, prim, t, u, v);
  // Facing away from the light: shading skips the light, the mask and the refinement say 0.
  const Light& l = lights_[light];
  if (dot(s.ng, sample_light(l, s.p).to_light) <= 0) return 0;
  return visibility(s.p + s.ng * eps_, l, rays);
}

void CpuPass::run(const CpuPassInput& in, bool secondary_rays, bool refine,
                  CpuPassOutput& out) const {
  const Timer timer;
  const std::size_t n = static_cast<std::size_t>(in.width) * in.height;
  out.color.assign(n, {0, 0, 0, 0});
  out.refined = in.mask;
  const int lights = static_cast<int>(std::min<std::size_t>(lights_.size(), 4));
  const std::size_t rows = static_cast<std::size_t>(in.height);
  std::vector<std::uint64_t> row_rays(rows, 0), row_secondary(rows, 0), row_boundary(rows, 0),
      row_boundary_rays(rows, 0), row_map_answers(rows, 0);
  parallel_chunks(rows, kRowsPerChunk, [&](std::size_t begin, std::size_t end) {
    for (std::size_t y = begin; y < end; ++y)
      for (int x = 0; x < in.width; ++x) {
        const std::size_t i = y * in.width + x;
        const std::uint32_t id = in.ids[i];
        if (id == 0) continue;
        const std::uint32_t prim = id - 1;
        const Material& m = flat_.materials[flat_.material[prim]];
        const bool needs_secondary = secondary_rays && (m.reflectivity > 0 || m.transparency > 0);
        bool any_boundary = false;
        for (int l = 0; l < lights; ++l) any_boundary = any_boundary || (refine && in.boundary[i][l]);
        if (!needs_secondary && !any_boundary) continue;
        const Ray ray = in.camera.generate(x + 0.5f, static_cast<float>(y) + 0.5f, in.width, in.height);
        float t, u, v;
        if (!plane_hit(ray, flat_.triangles[prim], t, u, v)) continue;
        const Surface s = surface(ray, prim, t, u, v);
        std::uint64_t& rays = row_rays[y];
        if (any_boundary) {
          ++row_boundary[y];
          const std::uint64_t before = rays;
          for (int l = 0; l < lights; ++l)
            if (in.boundary[i][l]) {
              const LightSample ls = sample_light(lights_[l], s.p);
              out.refined[i][l] = dot(s.ng, ls.to_light) <= 0
                                      ? 0.0f
                                      : visibility(s.p + s.ng * eps_, lights_[l], rays);
            }
          row_boundary_rays[y] += rays - before;
        }
        if (needs_secondary) {
          ++row_secondary[y];
          Trace t;
          t.maps = in.maps.empty() ? nullptr : &in.maps;
          const Vec3 c = secondary(ray, s, 0, t);
          rays += t.rays;
          row_map_answers[y] += t.map_answers;
          out.color[i] = {c.x, c.y, c.z, 0};
        }
      }
  });
  out.rays = out.boundary_rays = out.map_answers = 0;
  out.secondary_pixels = out.boundary_pixels = 0;
  for (std::size_t y = 0; y < rows; ++y) {
    out.rays += row_rays[y];
    out.boundary_rays += row_boundary_rays[y];
    out.map_answers += row_map_answers[y];
    out.secondary_pixels += row_secondary[y];
    out.boundary_pixels += row_boundary[y];
  }
  out.ms = timer.ms();
}

}  // namespace splitray::gl

#include "splitray/render_gl/cpu_pass.hpp"

#include <algorithm>
#include <cmath>
#include <optional>

#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/render/surface.hpp"
#include "splitray/render/tracer.hpp"

namespace splitray::gl {

namespace {
constexpr std::size_t kRowsPerChunk = 4;
}  // namespace

// The frame's shadow maps as the tracer's shadow answers.
class MapAnswers final : public ShadowAnswers {
 public:
  explicit MapAnswers(const std::vector<LightMap>& maps) : maps_(maps) {}
  int visibility(std::size_t light, const Vec3& p, const Vec3& ng) const override {
    return light < maps_.size() ? maps_[light].visibility(p, ng) : -1;
  }

 private:
  const std::vector<LightMap>& maps_;
};

CpuPass::CpuPass(const Scene& scene, const FlatScene& flat, const std::vector<Light>& lights,
                 const Accel& accel, int max_depth)
    : flat_(flat),
      tracer_(scene, flat, lights, accel, max_depth, offset_epsilon(bounds_of(flat.triangles))) {}

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
  if (!(fx >= 1 && fy >= 1 && fx < static_cast<float>(size - 1) &&
        fy < static_cast<float>(size - 1)))
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
  // Facing away from the light: shading skips the light, the mask and the refinement say 0.
  return tracer_.light_visibility(tracer_.surface(ray, prim, u, v), tracer_.lights()[light], rays);
}

void CpuPass::run(const CpuPassInput& in, bool secondary_rays, bool refine,
                  CpuPassOutput& out) const {
  const Timer timer;
  const std::size_t n = static_cast<std::size_t>(in.width) * in.height;
  out.color.assign(n, {0, 0, 0, 0});
  out.refined = in.mask;
  const int lights = static_cast<int>(std::min<std::size_t>(tracer_.lights().size(), 4));
  const std::size_t rows = static_cast<std::size_t>(in.height);
  std::vector<std::uint64_t> row_rays(rows, 0), row_secondary(rows, 0), row_boundary(rows, 0),
      row_boundary_rays(rows, 0), row_map_answers(rows, 0);
  const MapAnswers answers(in.maps);
  parallel_chunks(rows, kRowsPerChunk, [&](std::size_t begin, std::size_t end) {
    const int x1 = in.x1 < 0 ? in.width : std::min(in.x1, in.width);
    const int y1 = in.y1 < 0 ? in.height : std::min(in.y1, in.height);
    for (std::size_t y = begin; y < end; ++y) {
      if (static_cast<int>(y) < in.y0 || static_cast<int>(y) >= y1) continue;
      for (int x = std::max(in.x0, 0); x < x1; ++x) {
        const std::size_t i = y * in.width + x;
        const std::uint32_t id = in.ids[i];
        if (id == 0) continue;
        const std::uint32_t prim = id - 1;
        const Material& m = flat_.materials[flat_.material[prim]];
        const bool needs_secondary = secondary_rays && (m.reflectivity > 0 || m.transparency > 0);
        bool any_boundary = false;
        for (int l = 0; l < lights; ++l)
          any_boundary = any_boundary || (refine && in.boundary[i][l]);
        if (!needs_secondary && !any_boundary) continue;
        const Ray ray =
            in.camera.generate(x + 0.5f, static_cast<float>(y) + 0.5f, in.width, in.height);
        float t, u, v;
        if (!plane_hit(ray, flat_.triangles[prim], t, u, v)) continue;
        const SurfacePoint s = tracer_.surface(ray, prim, u, v);
        std::uint64_t& rays = row_rays[y];
        if (any_boundary) {
          ++row_boundary[y];
          const std::uint64_t before = rays;
          for (int l = 0; l < lights; ++l)
            if (in.boundary[i][l])
              out.refined[i][l] = tracer_.light_visibility(s, tracer_.lights()[l], rays);
          row_boundary_rays[y] += rays - before;
        }
        if (needs_secondary) {
          ++row_secondary[y];
          TraceCounters t;
          t.answers = in.maps.empty() ? nullptr : &answers;
          const Vec3 c = tracer_.secondary(s, 0, t);
          rays += t.rays;
          row_map_answers[y] += t.map_answers;
          out.color[i] = {c.x, c.y, c.z, 0};
        }
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

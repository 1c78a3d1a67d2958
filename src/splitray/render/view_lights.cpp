#include "splitray/render/view_lights.hpp"

#include <algorithm>

#include "splitray/render/shading.hpp"
#include "splitray/render/surface.hpp"

namespace splitray {

namespace {

constexpr int kProbesX = 32, kProbesY = 24;

struct Probe {
  Ray ray;  // unit direction
  Hit hit;
};

std::vector<Probe> probe_hits(const Accel& accel, const Camera& camera, int width, int height) {
  std::vector<Probe> probes;
  for (int j = 0; j < kProbesY; ++j)
    for (int i = 0; i < kProbesX; ++i) {
      const float x = (static_cast<float>(i) + 0.5f) * static_cast<float>(width) / kProbesX;
      const float y = (static_cast<float>(j) + 0.5f) * static_cast<float>(height) / kProbesY;
      Probe p{camera.generate(x, y, width, height), {}};
      p.hit = accel.intersect(p.ray);
      if (p.hit.found()) probes.push_back(p);
    }
  return probes;
}

float median(std::vector<float> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

Light point_light(const Vec3& position, float intensity) {
  Light light;
  light.kind = Light::Kind::point;
  light.position = position;
  light.intensity = std::max(intensity, 1e-20f);
  return light;
}

}  // namespace

std::vector<Light> fit_lights(const FlatScene& flat, const Accel& accel, const Camera& camera,
                              int width, int height) {
  const Aabb box = bounds_of(flat.triangles);
  const Vec3 up = normalize(camera.up);
  if (!box.contains(camera.eye)) {
    const Vec3 position =
        camera.eye + (camera.eye - camera.target) * 0.3f + up * length(box.extent());
    return {point_light(position, dot(position - camera.target, position - camera.target))};
  }
  const std::vector<Probe> probes = probe_hits(accel, camera, width, height);
  std::vector<float> distances;
  for (const Probe& p : probes) distances.push_back(p.hit.t);
  const float seen = probes.empty() ? 0.5f * length(box.extent()) : median(distances);
  std::vector<Light> lights{point_light(camera.eye, 0.6f * seen * seen)};  // the head light

  // The key light: halfway along the probe nearest the image centre (free space by
  // construction), raised halfway to whatever is above it (or the bounds' top).
  Vec3 start = camera.eye + normalize(camera.target - camera.eye) * (0.5f * seen);
  float best = kInfinity;
  for (const Probe& p : probes) {
    const float off_centre = 1 - dot(p.ray.dir, normalize(camera.target - camera.eye));
    if (off_centre < best) {
      best = off_centre;
      start = camera.eye + p.ray.dir * (0.5f * p.hit.t);
    }
  }
  const Hit above = accel.intersect(Ray{start, up});
  const float headroom = above.found() ? above.t : std::max(0.0f, box.hi.y - start.y);
  const Vec3 key = start + up * (0.5f * headroom);
  std::vector<float> key_distances;
  for (const Probe& p : probes)
    key_distances.push_back(length(p.ray.org + p.ray.dir * p.hit.t - key));
  const float reach = probes.empty() ? seen : median(key_distances);
  lights.push_back(point_light(key, 0.8f * reach * reach));
  return lights;
}

std::vector<Light> lights_for_view(const Scene& scene, const FlatScene& flat, const Accel& accel,
                                   const Camera& camera, int width, int height) {
  return scene.lights_fit_view ? fit_lights(flat, accel, camera, width, height) : scene.lights;
}

LightCoverage light_coverage(const std::vector<Light>& lights, const FlatScene& flat,
                             const Accel& accel, const Camera& camera, int width, int height) {
  const float eps = offset_epsilon(bounds_of(flat.triangles));
  LightCoverage coverage;
  for (const Probe& p : probe_hits(accel, camera, width, height)) {
    ++coverage.probes;
    const Triangle& tri = flat.triangles[p.hit.prim];
    Vec3 ng = normalize(tri.geometric_normal());
    if (dot(ng, p.ray.dir) > 0) ng = -ng;
    const Vec3 point = hit_position(tri, p.hit) + ng * eps;
    for (const Light& light : lights) {
      const LightSample s = sample_light(light, point);
      if (dot(ng, s.to_light) <= 0 || !(max_component(s.radiance) > 0)) continue;
      if (!accel.occluded(Ray{point, s.to_light, 0, s.distance})) {
        ++coverage.lit;
        break;
      }
    }
  }
  return coverage;
}

std::string coverage_warning(const LightCoverage& coverage, std::size_t light_count) {
  if (coverage.probes == 0) return "the camera sees nothing of the scene (check --camera)";
  if (coverage.lit > 0) return {};
  if (light_count == 0) return "the scene has no lights: only ambient light shows";
  return "no light of the scene (" + std::to_string(light_count) +
         ") reaches what the camera sees: only ambient light shows";
}

}  // namespace splitray

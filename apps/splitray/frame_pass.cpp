#include "frame_pass.hpp"

#include "splitray/core/timer.hpp"
#include "splitray/render/surface.hpp"

namespace splitray::app {

FramePassSetup frame_pass_setup(const FrameSequence& sequence, const std::vector<Triangle>& first,
                                int width, int height) {
  FramePassSetup setup;
  setup.width = width;
  setup.height = height;
  const Aabb bounds = bounds_of(first);
  setup.fixed_camera = Camera::frame(bounds);
  // A point light above the first frame and in front of it (towards the framing camera),
  // as a key light would stand: most hits see it, surfaces turned away are shadowed.
  const Vec3 extent = bounds.extent();
  setup.light = bounds.center() + Vec3{0, 1.5f * extent.y, 0} +
                (setup.fixed_camera.eye - bounds.center()) * 0.5f;
  if (const auto scene = sequence.scene(); scene && !scene->lights.empty()) {
    const Light& light = scene->lights.front();
    setup.light = light.kind == Light::Kind::directional
                      ? bounds.center() - light.direction * (4 * length(extent))
                      : light.position;
  }
  return setup;
}

FramePassResult trace_frame_pass(const FramePassSetup& setup, const FrameSequence& sequence,
                                 std::size_t frame, const Accel& accel,
                                 const std::vector<Triangle>& triangles) {
  const Camera camera = sequence.camera(frame).value_or(setup.fixed_camera);
  const std::size_t n = static_cast<std::size_t>(setup.width) * setup.height;
  std::vector<Ray> primary(n);
  for (int y = 0; y < setup.height; ++y)
    for (int x = 0; x < setup.width; ++x)
      primary[static_cast<std::size_t>(y) * setup.width + x] = camera.generate(
          static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f, setup.width, setup.height);
  FramePassResult result;
  result.hits.resize(n);
  Timer timer;
  accel.intersect(primary, result.hits);
  result.trace_ms = timer.ms();
  // One shadow ray per hit, from just off the surface on the light's side.
  const float eps = offset_epsilon(bounds_of(triangles));
  std::vector<Ray> shadow;
  std::vector<std::size_t> of;
  shadow.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Hit& h = result.hits[i];
    if (!h.found()) continue;
    const Triangle& t = triangles[h.prim];
    const Vec3 p = hit_position(t, h);
    Vec3 ng = normalize(t.geometric_normal());
    if (dot(ng, setup.light - p) < 0) ng = -ng;
    const Vec3 org = p + ng * eps;
    shadow.push_back(Ray{org, setup.light - org, 0, 1});
    of.push_back(i);
  }
  std::vector<std::uint8_t> occluded(shadow.size());
  timer.reset();
  accel.occluded(shadow, occluded);
  result.trace_ms += timer.ms();
  result.rays = n + shadow.size();
  result.shadowed.assign(n, 0);
  for (std::size_t k = 0; k < of.size(); ++k) result.shadowed[of[k]] = occluded[k];
  return result;
}

}  // namespace splitray::app

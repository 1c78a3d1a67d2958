#include "splitray/render_gl/light_space.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>

namespace splitray::gl {

namespace {

glm::vec3 to_glm(const Vec3& v) { return {v.x, v.y, v.z}; }

std::array<glm::vec3, 8> corners(const Aabb& box) {
  std::array<glm::vec3, 8> c;
  for (int i = 0; i < 8; ++i)
    c[i] = {(i & 1) ? box.hi.x : box.lo.x, (i & 2) ? box.hi.y : box.lo.y,
            (i & 4) ? box.hi.z : box.lo.z};
  return c;
}

// Near and far distances along the view direction that hold all of `box`.
std::pair<float, float> depth_range(const Camera& camera, const Aabb& box) {
  const glm::vec3 eye = to_glm(camera.eye), forward = glm::normalize(to_glm(camera.target - camera.eye));
  float far = 0;
  for (const glm::vec3& c : corners(box)) far = std::max(far, glm::dot(c - eye, forward));
  far = std::max(far * 1.01f, 1e-3f);
  return {far * 2e-4f, far};
}

// The part of the view frustum inside the scene: the frustum's corners clamped to `box`.
std::vector<glm::vec3> focus_body(const Camera& camera, float aspect, const Aabb& box) {
  const auto [near, far] = depth_range(camera, box);
  const glm::vec3 eye = to_glm(camera.eye), forward = glm::normalize(to_glm(camera.target - camera.eye));
  const glm::vec3 right = glm::normalize(glm::cross(forward, to_glm(camera.up)));
  const glm::vec3 up = glm::cross(right, forward);
  const float t = std::tan(glm::radians(camera.vfov_degrees) * 0.5f);
  std::vector<glm::vec3> body;
  for (float d : {near, far * 0.25f, far * 0.5f, far})
    for (int sx : {-1, 1})
      for (int sy : {-1, 1}) {
        const glm::vec3 p = eye + forward * d + right * (sx * d * t * aspect) + up * (sy * d * t);
        body.push_back(glm::clamp(p, to_glm(box.lo), to_glm(box.hi)));
      }
  return body;
}

// Scales x and y of `projection` so that `receivers` fill [-1, 1] and z so that `casters`
// (depth from the light: -z/w) fill [-1, 1].
glm::mat4 fit(const glm::mat4& projection, const std::vector<glm::vec3>& receivers,
              const std::vector<glm::vec3>& casters) {
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const glm::vec3& p : receivers) {
    const glm::vec4 c = projection * glm::vec4(p, 1);
    lo = glm::min(lo, glm::vec3(c) / c.w);
    hi = glm::max(hi, glm::vec3(c) / c.w);
  }
  float zlo = 1e30f, zhi = -1e30f;
  for (const glm::vec3& p : casters) {
    const glm::vec4 c = projection * glm::vec4(p, 1);
    zlo = std::min(zlo, -c.z / c.w);
    zhi = std::max(zhi, -c.z / c.w);
  }
  const float pad = 1e-3f;
  const float sx = 2 / std::max(hi.x - lo.x + pad, 1e-6f), sy = 2 / std::max(hi.y - lo.y + pad, 1e-6f);
  const float sz = 2 / std::max(zhi - zlo + pad, 1e-6f);
  const float cx = 0.5f * (lo.x + hi.x), cy = 0.5f * (lo.y + hi.y), cz = 0.5f * (zlo + zhi);
  glm::mat4 s(0.0f);  // columns
  s[0][0] = sx;
  s[3][0] = -sx * cx;
  s[1][1] = sy;
  s[3][1] = -sy * cy;
  s[2][2] = -sz;
  s[3][2] = -sz * cz;
  s[3][3] = 1;
  return s * projection;
}

glm::vec3 any_perpendicular(const glm::vec3& v) {
  const glm::vec3 a = std::abs(v.x) < 0.9f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
  return glm::normalize(glm::cross(v, a));
}

}  // namespace

glm::mat4 camera_matrix(const Camera& camera, int width, int height, const Aabb& bounds) {
  const auto [near, far] = depth_range(camera, bounds);
  const glm::mat4 view = glm::lookAt(to_glm(camera.eye), to_glm(camera.target), to_glm(camera.up));
  return glm::perspective(glm::radians(camera.vfov_degrees),
                          static_cast<float>(width) / static_cast<float>(height), near, far) *
         view;
}

glm::mat4 directional_light_matrix(const Camera& camera, float aspect, const Vec3& light_dir,
                                   const Aabb& bounds, bool lispsm) {
  const glm::vec3 l = glm::normalize(to_glm(light_dir));
  const glm::vec3 v = glm::normalize(to_glm(camera.target - camera.eye));
  const std::vector<glm::vec3> body = focus_body(camera, aspect, bounds);
  const auto box = corners(bounds);
  const float cos_gamma = glm::dot(v, l);
  const float sin_gamma = std::sqrt(std::max(0.0f, 1 - cos_gamma * cos_gamma));
  const glm::vec3 center = to_glm(bounds.center());
  const float radius = 0.5f * length(bounds.extent()) + 1e-3f;

  if (!lispsm || sin_gamma < 0.05f) {  // uniform shadow map
    const glm::mat4 view = glm::lookAt(center - l * radius, center, any_perpendicular(l));
    return fit(view, body, {box.begin(), box.end()});
  }
  // LiSPSM: a perspective along the view direction projected perpendicular to the light.
  const glm::vec3 up = glm::normalize(glm::cross(glm::cross(l, v), l));
  const glm::vec3 eye = to_glm(camera.eye);
  const glm::mat4 light_view = glm::lookAt(eye, eye + l, up);
  float ylo = 1e30f, yhi = -1e30f;
  for (const glm::vec3& p : body) {
    const float y = (light_view * glm::vec4(p, 1)).y;
    ylo = std::min(ylo, y);
    yhi = std::max(yhi, y);
  }
  const float near_dist = depth_range(camera, bounds).first;
  const float d = std::max(yhi - ylo, 1e-4f);
  const float z_n = near_dist / sin_gamma;
  const float z_f = z_n + d * sin_gamma;
  const float n = (z_n + std::sqrt(z_f * z_n)) / sin_gamma;
  const float f = n + d;
  const glm::vec3 position = eye + up * (ylo - n);  // receivers at y in [n, f]
  const glm::mat4 lisp_view = glm::lookAt(position, position + l, up);
  glm::mat4 perspective(0.0f);  // y becomes the perspective axis
  perspective[0][0] = 1;
  perspective[1][1] = (f + n) / (f - n);
  perspective[3][1] = -2 * f * n / (f - n);
  perspective[2][2] = 1;
  perspective[1][3] = 1;
  // Casters: every corner of the scene at the receivers' y range (a caster shadows a
  // receiver at its own y, the light travelling perpendicular to y).
  std::vector<glm::vec3> casters;
  const glm::mat4 inverse = glm::inverse(lisp_view);
  for (const glm::vec3& c : box) {
    glm::vec4 p = lisp_view * glm::vec4(c, 1);
    for (float y : {n, f}) casters.push_back(glm::vec3(inverse * glm::vec4(p.x, y, p.z, 1)));
  }
  return fit(perspective * lisp_view, body, casters);
}

std::array<glm::mat4, 6> cube_face_matrices(const Vec3& position, float range) {
  const glm::vec3 p = to_glm(position);
  const glm::mat4 projection = glm::perspective(glm::radians(90.0f), 1.0f, range * 1e-5f, range);
  const glm::vec3 dirs[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  const glm::vec3 ups[6] = {{0, -1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}, {0, -1, 0}, {0, -1, 0}};
  std::array<glm::mat4, 6> m;
  for (int i = 0; i < 6; ++i) m[i] = projection * glm::lookAt(p, p + dirs[i], ups[i]);
  return m;
}

}  // namespace splitray::gl

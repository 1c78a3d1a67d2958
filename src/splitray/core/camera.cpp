#include "splitray/core/camera.hpp"

#include <cmath>
#include <numbers>

#include "splitray/core/coordinates.hpp"

namespace splitray {

Ray Camera::generate(float x, float y, int width, int height) const {
  const Vec3 forward = normalize(target - eye);
  Vec3 right = cross(forward, up);
  if (dot(right, right) == 0) right = cross(forward, Vec3{0, 0, 1});
  right = normalize(right);
  const Vec3 true_up = cross(right, forward);
  const float tan_half = std::tan(vfov_degrees * std::numbers::pi_v<float> / 360.0f);
  const float aspect = static_cast<float>(width) / static_cast<float>(height);
  const float sx = (2.0f * x / static_cast<float>(width) - 1.0f) * tan_half * aspect;
  const float sy = (1.0f - 2.0f * y / static_cast<float>(height)) * tan_half;
  return Ray{eye, normalize(forward + right * sx + true_up * sy), 0.0f, kInfinity};
}

Camera Camera::frame(const Aabb& box, float vfov_degrees) {
  Camera cam;
  cam.vfov_degrees = vfov_degrees;
  cam.target = box.center();
  const float radius = std::max(0.5f * length(box.extent()), 1e-6f);
  const float distance = radius / std::sin(vfov_degrees * std::numbers::pi_v<float> / 360.0f);
  const Vec3 direction = normalize(Vec3{0.6f, 0.45f, 1.0f});
  cam.eye = cam.target + direction * distance;
  return cam;
}

std::string Camera::problem() const {
  if (const std::string p = origin_problem(eye); !p.empty()) return "the eye has " + p;
  if (const std::string p = origin_problem(target); !p.empty()) return "the target has " + p;
  if (!is_finite(up) || up == Vec3{}) return "the up vector is zero or not finite";
  if (eye == target) return "the eye and the target are the same point";
  if (!(vfov_degrees > 0 && vfov_degrees < 180))
    return "the field of view must lie between 0 and 180 degrees";
  return {};
}

}  // namespace splitray

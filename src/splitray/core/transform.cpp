#include "splitray/core/transform.hpp"

#include <cmath>
#include <numbers>

namespace splitray {

Transform Transform::translate(const Vec3& t) {
  Transform r;
  r.m[3] = t.x;
  r.m[7] = t.y;
  r.m[11] = t.z;
  return r;
}

Transform Transform::scale(const Vec3& s) {
  Transform r;
  r.m[0] = s.x;
  r.m[5] = s.y;
  r.m[10] = s.z;
  return r;
}

Transform Transform::rotate(const Vec3& axis, float degrees) {
  const Vec3 a = normalize(axis);
  const float rad = degrees * std::numbers::pi_v<float> / 180.0f;
  const float c = std::cos(rad), s = std::sin(rad), k = 1 - c;
  Transform r;
  r.m = {a.x * a.x * k + c,       a.x * a.y * k - a.z * s, a.x * a.z * k + a.y * s, 0,
         a.y * a.x * k + a.z * s, a.y * a.y * k + c,       a.y * a.z * k - a.x * s, 0,
         a.z * a.x * k - a.y * s, a.z * a.y * k + a.x * s, a.z * a.z * k + c,       0};
  return r;
}

Vec3 Transform::normal(const Vec3& n) const {
  // Cofactor matrix of the linear part = det * inverse transpose; the scale drops out
  // after normalisation.
  const Vec3 c0{m[0], m[4], m[8]}, c1{m[1], m[5], m[9]}, c2{m[2], m[6], m[10]};
  const Vec3 r0 = cross(c1, c2), r1 = cross(c2, c0), r2 = cross(c0, c1);
  const Vec3 out = r0 * n.x + r1 * n.y + r2 * n.z;
  const float det = dot(c0, r0);
  return normalize(det < 0 ? -out : out);
}

Transform Transform::operator*(const Transform& o) const {
  Transform r;
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 4; ++col) {
      float sum = col == 3 ? m[row * 4 + 3] : 0.0f;
      for (int k = 0; k < 3; ++k) sum += m[row * 4 + k] * o.m[k * 4 + col];
      r.m[row * 4 + col] = sum;
    }
  }
  return r;
}

}  // namespace splitray

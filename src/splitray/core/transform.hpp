#pragma once
// Affine transforms (3x4 row-major) for mesh instances.
#include <array>

#include "splitray/core/vec.hpp"

namespace splitray {

struct Transform {
  std::array<float, 12> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};

  static Transform translate(const Vec3& t);
  static Transform scale(const Vec3& s);
  static Transform rotate(const Vec3& axis, float degrees);

  Vec3 point(const Vec3& p) const {
    return {m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
            m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]};
  }
  Vec3 vector(const Vec3& v) const {
    return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[4] * v.x + m[5] * v.y + m[6] * v.z,
            m[8] * v.x + m[9] * v.y + m[10] * v.z};
  }
  // Normals transform by the inverse transpose of the linear part.
  Vec3 normal(const Vec3& n) const;
  // this * other: apply `other` first.
  Transform operator*(const Transform& other) const;
};

}  // namespace splitray

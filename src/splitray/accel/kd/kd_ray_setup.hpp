#pragma once
// Per-ray constants of the kd traversal (kd_traverse.cpp explains the widening), shared by the
// single-ray and the packet traversal so that both clip every ray identically. The packet
// traversal (kd_packet.cpp) repeats these float operations lane by lane in SIMD: change both
// together.
#include <algorithm>
#include <cmath>
#include <limits>

#include "splitray/core/aabb.hpp"
#include "splitray/core/ray.hpp"

namespace splitray {

struct KdRaySetup {
  float inv[3], pad[3], org[3];
  float t0, t1;  // the ray's widened interval in the root cell

  // False for rays with a NaN, infinite or zero direction or origin (test every reference).
  static bool traversable(const Ray& ray) {
    return is_finite(ray.org) && is_finite(ray.dir) && max_component(abs(ray.dir)) > 0;
  }

  KdRaySetup() = default;
  // For a traversable ray with ray.tmin <= ray.tmax; `coord_scale` is the largest absolute
  // coordinate of `box`.
  KdRaySetup(const Ray& ray, const Aabb& box, float coord_scale) {
    const float max_dir = max_component(abs(ray.dir));
    // Direction components near zero are made tiny but non-zero: the inverse stays finite, and
    // the widening covers the difference.
    const float tiny = std::max(max_dir * 0x1p-40f, std::numeric_limits<float>::min());
    const Vec3 far_corner = max(abs(ray.org - box.lo), abs(ray.org - box.hi));  // L1 >= distance
    const float delta = 0x1p-18f * (far_corner.x + far_corner.y + far_corner.z + coord_scale);
    const float pad_t = delta / max_dir;
    t0 = ray.tmin;
    t1 = ray.tmax;
    for (int a = 0; a < 3; ++a) {
      float d = ray.dir[a];
      if (std::fabs(d) < tiny) d = std::copysign(tiny, d);
      inv[a] = 1.0f / d;
      pad[a] = delta * std::fabs(inv[a]) + pad_t;
      org[a] = ray.org[a];
      const float ta = (box.lo[a] - org[a]) * inv[a], tb = (box.hi[a] - org[a]) * inv[a];
      const float enter = std::min(ta, tb) - pad[a], leave = std::max(ta, tb) + pad[a];
      if (enter > t0) t0 = enter;  // comparisons written so that NaN (inf - inf) widens
      if (leave < t1) t1 = leave;
    }
  }
};

}  // namespace splitray

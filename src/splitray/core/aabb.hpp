#pragma once
// Axis-aligned bounding box. An empty box has lo > hi and absorbs nothing.
#include <limits>

#include "splitray/core/vec.hpp"

namespace splitray {

struct Aabb {
  Vec3 lo{std::numeric_limits<float>::infinity()};
  Vec3 hi{-std::numeric_limits<float>::infinity()};

  constexpr Aabb() = default;
  constexpr Aabb(const Vec3& lo_, const Vec3& hi_) : lo(lo_), hi(hi_) {}

  bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  void extend(const Vec3& p) { lo = min(lo, p); hi = max(hi, p); }
  void extend(const Aabb& b) { lo = min(lo, b.lo); hi = max(hi, b.hi); }
  Vec3 extent() const { return hi - lo; }
  Vec3 center() const { return (lo + hi) * 0.5f; }
  float half_area() const {
    if (empty()) return 0;
    const Vec3 e = extent();
    return e.x * e.y + e.y * e.z + e.z * e.x;
  }
  float area() const { return 2 * half_area(); }
  int longest_axis() const { return max_axis(extent()); }
  bool contains(const Vec3& p) const {
    return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
  }
  friend Aabb intersection(const Aabb& a, const Aabb& b) { return {max(a.lo, b.lo), min(a.hi, b.hi)}; }
  friend Aabb merge(Aabb a, const Aabb& b) { a.extend(b); return a; }
};

}  // namespace splitray

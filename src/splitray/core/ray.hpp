#pragma once
// Rays and hit records, with the one tie-breaking rule every hierarchy follows.
#include <cstdint>
#include <limits>

#include "splitray/core/vec.hpp"

namespace splitray {

inline constexpr std::uint32_t kInvalidId = std::numeric_limits<std::uint32_t>::max();
inline constexpr float kInfinity = std::numeric_limits<float>::infinity();

struct Ray {
  Vec3 org;
  Vec3 dir;  // need not be normalised; t is measured in units of dir
  float tmin = 0;
  float tmax = kInfinity;
};

struct Hit {
  float t = kInfinity;
  std::uint32_t prim = kInvalidId;  // index into the triangle soup the structure was built on
  float u = 0, v = 0;               // barycentrics of vertices 1 and 2

  bool found() const { return prim != kInvalidId; }
  // Closest-hit order: smaller t, and on a tie (rays through shared edges or vertices)
  // the smaller primitive id, so that every correct structure reports the same hit.
  bool closer_than(const Hit& o) const { return t < o.t || (t == o.t && prim < o.prim); }
};

}  // namespace splitray

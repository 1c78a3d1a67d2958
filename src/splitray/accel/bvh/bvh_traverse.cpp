// Ordered BVH traversal: both children's boxes are tested, the nearer entered first, the
// other pushed with its entry distance and skipped when popped behind the closest hit. A node
// entered at t <= the closest hit is still searched, so ties at equal t go to the smaller
// primitive id exactly as in `brute`.
#include "splitray/accel/bvh/bvh.hpp"
#include "splitray/accel/bvh/robust_ray.hpp"

namespace splitray {

namespace {

constexpr int kStackSize = 64;  // the depth bound of every builder

// Entry parameter of the ray into the node's box within [tmin, tmax], or false on a miss.
inline bool enter(const BvhNode& n, const RobustRay& r, float tmin, float tmax, float& t_entry) {
  float t0 = tmin, t1 = tmax;
  for (int a = 0; a < 3; ++a) {
    t0 = max_keep(t0, r.entry(a, n.lo[a], n.hi[a]));
    t1 = min_keep(t1, r.exit(a, n.lo[a], n.hi[a]));
  }
  t_entry = t0;
  return t0 <= t1;
}

template <bool AnyHit>
bool traverse(std::span<const BvhNode> nodes, std::span<const Triangle> tris, std::span<const std::uint32_t> ids,
              const Ray& ray, const RobustRay& r, Hit& hit) {
  const WatertightRay w(ray);
  struct Entry {
    std::uint32_t node;
    float t;
  };
  Entry stack[kStackSize];
  int sp = 0;
  float t_root;
  if (!enter(nodes[0], r, ray.tmin, hit.t, t_root)) return false;
  std::uint32_t node = 0;
  for (;;) {
    const BvhNode& n = nodes[node];
    if (!n.leaf()) {
      float t0, t1;
      const bool h0 = enter(nodes[n.index], r, ray.tmin, hit.t, t0);
      const bool h1 = enter(nodes[n.index + 1], r, ray.tmin, hit.t, t1);
      if (h0 && h1) {
        const bool second_first = t1 < t0;
        stack[sp++] = {n.index + (second_first ? 0u : 1u), second_first ? t0 : t1};
        node = n.index + (second_first ? 1u : 0u);
        continue;
      }
      if (h0 || h1) {
        node = n.index + (h0 ? 0u : 1u);
        continue;
      }
    } else {
      const std::uint32_t end = n.index + n.count();
      for (std::uint32_t i = n.index; i < end; ++i) {
        if constexpr (AnyHit) {
          float t, u, v;
          if (intersect_triangle(w, tris[i], ray.tmin, ray.tmax, t, u, v)) return true;
        } else {
          intersect_triangle(w, tris[i], ids[i], ray.tmin, hit);
        }
      }
    }
    for (;;) {  // pop the next node not behind the closest hit
      if (sp == 0) return hit.found();
      const Entry e = stack[--sp];
      if (e.t <= hit.t) {
        node = e.node;
        break;
      }
    }
  }
}

}  // namespace

Hit Bvh::intersect(const Ray& ray) const {
  Hit hit;
  if (nodes_.empty()) return hit;
  hit.t = ray.tmax;
  const RobustRay r(ray, scene_, magnitude_);
  traverse<false>(nodes_, tris_, ids_, ray, r, hit);
  if (!hit.found()) hit.t = kInfinity;
  return hit;
}

bool Bvh::occluded(const Ray& ray) const {
  if (nodes_.empty()) return false;
  Hit hit;
  hit.t = ray.tmax;
  const RobustRay r(ray, scene_, magnitude_);
  return traverse<true>(nodes_, tris_, ids_, ray, r, hit);
}

}  // namespace splitray

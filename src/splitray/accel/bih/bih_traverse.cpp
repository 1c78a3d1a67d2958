// BIH traversal (paper 004): like a kd-tree, the ray's parameter interval is clipped at the
// node's planes, giving four cases (only the near child, only the far child, both -- far one
// pushed --, or neither, which a kd-tree never has) plus the fifth for one-child nodes (the
// child's interval, or nothing). Planes are conservative (robust_ray.hpp, the box style) and a
// popped node is searched while its entry is not behind the closest hit (traversal_stack.hpp),
// so ties resolve as in `brute`.
#include <algorithm>

#include "splitray/accel/bih/bih.hpp"
#include "splitray/accel/robust_ray.hpp"
#include "splitray/accel/traversal_stack.hpp"

namespace splitray {

namespace {

constexpr int kStackSize = 64;

template <bool AnyHit>
bool traverse(std::span<const BihNode> nodes, std::span<const Triangle> tris,
              std::span<const std::uint32_t> ids, const Aabb& scene, float magnitude,
              const Ray& ray, Hit& hit) {
  const RobustRay r(ray, scene, magnitude);
  float tn = ray.tmin, tf = hit.t;
  for (int a = 0; a < 3; ++a) {
    tn = max_keep(tn, r.entry(a, scene.lo[a], scene.hi[a]));
    tf = min_keep(tf, r.exit(a, scene.lo[a], scene.hi[a]));
  }
  if (!(tn <= tf)) return false;
  const WatertightRay w(ray);
  struct Entry {
    std::uint32_t node;
    float t0, t1;  // entry and exit
  };
  TraversalStack<Entry, kStackSize> stack;
  std::uint32_t node = 0;
  for (;;) {
    const BihNode& n = nodes[node];
    if (!n.leaf()) {
      const int a = n.axis();
      const int neg = r.negative[a];
      const std::uint32_t child = n.child();
      if (n.one_child()) {
        tn = max_keep(tn, (n.clip[neg] - r.org_near[a]) * r.inv[a]);
        tf = min_keep(tf, (n.clip[1 - neg] - r.org_far[a]) * r.inv[a]);
        if (tn <= tf) {
          node = child;
          continue;
        }
      } else {
        // Near child: the left one (x <= clip[0]) for a positive direction, else the right one.
        const float t_exit_near = (n.clip[neg] - r.org_far[a]) * r.inv[a];
        const float t_entry_far = (n.clip[1 - neg] - r.org_near[a]) * r.inv[a];
        const bool near_hit = !(tn > t_exit_near);  // NaN (ray in the plane): enter
        const bool far_hit = !(t_entry_far > tf);
        if (near_hit) {
          if (far_hit) stack.push({child + 1 - neg, max_keep(tn, t_entry_far), tf});
          node = child + neg;
          tf = min_keep(tf, t_exit_near);
          continue;
        }
        if (far_hit) {
          node = child + 1 - neg;
          tn = max_keep(tn, t_entry_far);
          continue;
        }
      }
    } else {
      const std::uint32_t end = n.first() + n.count();
      for (std::uint32_t i = n.first(); i < end; ++i) {
        if constexpr (AnyHit) {
          float t, u, v;
          if (intersect_triangle(w, tris[i], ray.tmin, ray.tmax, t, u, v)) return true;
        } else {
          intersect_triangle(w, tris[i], ids[i], ray.tmin, hit);
        }
      }
    }
    const Entry* next = stack.pop_not_behind(hit.t);
    if (!next) return hit.found();
    node = next->node;
    tn = next->t0;
    tf = std::min(next->t1, hit.t);
  }
}

}  // namespace

Hit Bih::intersect(const Ray& ray) const {
  Hit hit;
  if (nodes_.empty()) return hit;
  hit.t = ray.tmax;
  traverse<false>(nodes_, tris_, ids_, scene_, magnitude_, ray, hit);
  if (!hit.found()) hit.t = kInfinity;
  return hit;
}

bool Bih::occluded(const Ray& ray) const {
  if (nodes_.empty()) return false;
  Hit hit;
  hit.t = ray.tmax;
  return traverse<true>(nodes_, tris_, ids_, scene_, magnitude_, ray, hit);
}

}  // namespace splitray

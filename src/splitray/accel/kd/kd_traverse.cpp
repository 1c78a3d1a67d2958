// Front-to-back kd traversal with a fixed stack, exact against `brute`.
//
// Why it never loses the closest hit: every leaf test uses the watertight triangle test with
// [ray.tmin, best t], so whatever a leaf reports is what brute computes for that triangle, and
// the answer is the smallest (t, id) among the triangles tested. It is brute's answer as long
// as no triangle that could beat it is skipped. Three kinds of rounding could skip one: when
// the ray is clipped against split planes (and rays in or parallel to a plane), when the
// builder clipped a triangle to a cell (perfect splits may miss a cell the triangle reaches
// by an ulp), and in the triangle test's t, which may place a hit slightly before the cell it
// lies in. So every cell is widened by `delta` in space and its t-range by `delta / max|dir|`
// (delta = 2^-18 of the scale of the scene and the ray: far above float rounding, far below
// any cell that matters for speed), and a far cell is skipped only when its widened entry t
// exceeds the best t (strictly: on equal t a smaller id may wait there).
#include <cmath>
#include <limits>

#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/accel/kd/kd_sah.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

struct StackEntry {
  std::uint32_t node;
  float t0, t1;
};

}  // namespace

// Rays with a NaN, infinite or zero direction or origin: test every reference, as brute does.
template <bool kAnyHit>
bool KdAccel::scan(const Ray& ray, Hit& hit) const {
  const WatertightRay wray(ray);
  for (std::size_t i = 0; i < leaf_triangles_.size(); ++i) {
    if constexpr (kAnyHit) {
      float t, u, v;
      if (intersect_triangle(wray, leaf_triangles_[i], ray.tmin, ray.tmax, t, u, v)) return true;
    } else {
      intersect_triangle(wray, leaf_triangles_[i], tree_.prim_ids[i], ray.tmin, hit);
    }
  }
  return hit.found();
}

template <bool kAnyHit>
bool KdAccel::traverse(const Ray& ray, Hit& hit) const {
  hit.t = ray.tmax;
  if (!(ray.tmin <= ray.tmax)) return false;  // no t qualifies (also NaN bounds)
  const float max_dir = max_component(abs(ray.dir));
  if (!is_finite(ray.org) || !is_finite(ray.dir) || !(max_dir > 0)) return scan<kAnyHit>(ray, hit);

  // Direction components near zero are made tiny but non-zero: the inverse stays finite, and
  // the widening below covers the difference.
  const float tiny = std::max(max_dir * 0x1p-40f, std::numeric_limits<float>::min());
  const Aabb& box = tree_.bounds;
  const Vec3 far_corner = max(abs(ray.org - box.lo), abs(ray.org - box.hi));  // L1 norm >= distance
  const float delta = 0x1p-18f * (far_corner.x + far_corner.y + far_corner.z + coord_scale_);
  const float pad_t = delta / max_dir;
  float inv[3], pad[3], org[3];
  float t0 = ray.tmin, t1 = ray.tmax;
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
  if (!(t0 <= t1)) return false;

  const WatertightRay wray(ray);
  const KdNode* nodes = tree_.nodes.data();
  const Triangle* triangles = leaf_triangles_.data();
  const std::uint32_t* ids = tree_.prim_ids.data();
  StackEntry stack[kKdDepthLimit];
  int top = 0;
  std::uint32_t index = 0;
  for (;;) {
    const KdNode node = nodes[index];
    if (!node.is_leaf()) {
      __builtin_prefetch(nodes + node.above());  // in case the ray goes there next
      const int a = node.axis();
      const float t_split = (node.split - org[a]) * inv[a];
      const float hi = t_split + pad[a], lo = t_split - pad[a];
      std::uint32_t first = index + 1, second = node.above();
      if (inv[a] < 0) std::swap(first, second);
      const float first_t1 = hi < t1 ? hi : t1;
      const float second_t0 = lo > t0 ? lo : t0;
      if (t0 <= first_t1) {
        if (second_t0 <= t1) stack[top++] = {second, second_t0, t1};
        index = first;
        t1 = first_t1;
        continue;
      }
      index = second;
      t0 = second_t0;
      continue;
    }

    const std::uint32_t begin = node.prim_offset, end = begin + node.count();
    for (std::uint32_t i = begin; i < end; ++i) {
      if constexpr (kAnyHit) {
        float t, u, v;
        if (intersect_triangle(wray, triangles[i], ray.tmin, ray.tmax, t, u, v)) return true;
      } else {
        intersect_triangle(wray, triangles[i], ids[i], ray.tmin, hit);
      }
    }
    for (;;) {
      if (top == 0) return hit.found();
      const StackEntry& entry = stack[--top];
      if (kAnyHit || entry.t0 <= hit.t) {
        index = entry.node;
        t0 = entry.t0;
        t1 = entry.t1;
        break;
      }
    }
  }
}

Hit KdAccel::intersect(const Ray& ray) const {
  Hit hit;
  if (!traverse<false>(ray, hit)) hit = Hit{};
  return hit;
}

bool KdAccel::occluded(const Ray& ray) const {
  Hit unused;
  return traverse<true>(ray, unused);
}

void KdAccel::intersect(std::span<const Ray> rays, std::span<Hit> hits) const {
  if (hits.size() < rays.size()) throw Error("kd intersect", "fewer hit slots than rays");
  parallel_chunks(rays.size(), 256, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) hits[i] = KdAccel::intersect(rays[i]);
  });
}

void KdAccel::occluded(std::span<const Ray> rays, std::span<std::uint8_t> result) const {
  if (result.size() < rays.size()) throw Error("kd occluded", "fewer result slots than rays");
  parallel_chunks(rays.size(), 256, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) result[i] = KdAccel::occluded(rays[i]) ? 1 : 0;
  });
}

}  // namespace splitray

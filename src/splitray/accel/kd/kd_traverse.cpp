// Front-to-back kd traversal with a fixed stack, exact against `brute`.
//
// Why it never loses the closest hit: every leaf test uses the watertight triangle test with
// [ray.tmin, best t], so whatever a leaf reports is what brute computes for that triangle, and
// the answer is the smallest (t, id) among the triangles tested. It is brute's answer as long
// as no triangle that could beat it is skipped. Every leaf holds each triangle that reaches
// its cell: the builders' perfect-split clipping is conservative (accel/triangle_clip.hpp),
// which no margin here could make up for, since half an ulp across a plane nearly parallel
// to a triangle moves its crossing far along the plane. What is left is rounding in the
// traversal and in the triangle test: when the ray is clipped against split planes (and rays
// in or parallel to a plane), and in the test's t, which may place a hit slightly outside the
// cell it lies in (never far: the test decides slivers and degenerate triangles in double,
// core/triangle.hpp). So every cell is widened by `delta` in space and its t-range by
// `delta / max|dir|` (delta = 2^-18 of the scale of the scene and the ray: far above float
// rounding, far below any cell that matters for speed), and a far cell is skipped only when
// its widened entry t exceeds the best t (strictly: on equal t a smaller id may wait there).
#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/accel/kd/kd_ray_setup.hpp"
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
  const std::uint32_t* ids = tree_.prim_ids.data();
  for (const KdNode& node : tree_.nodes) {
    if (!node.is_leaf() || node.count() == 0) continue;
    const std::uint32_t first = node.prim_offset;
    if (intersect_leaf<kAnyHit>(wray, leaf_triangles_.leaf(first), ids + first, node.count(),
                                ray.tmin, ray.tmax, hit) &&
        kAnyHit)
      return true;
  }
  return hit.found();
}

template <bool kAnyHit>
bool KdAccel::traverse(const Ray& ray, Hit& hit) const {
  hit.t = ray.tmax;
  if (!(ray.tmin <= ray.tmax)) return false;  // no t qualifies (also NaN bounds)
  if (!KdRaySetup::traversable(ray)) return scan<kAnyHit>(ray, hit);
  const KdRaySetup setup(ray, tree_.bounds, coord_scale_);
  const float* inv = setup.inv;
  const float* pad = setup.pad;
  const float* org = setup.org;
  float t0 = setup.t0, t1 = setup.t1;
  if (!(t0 <= t1)) return false;
#if defined(__AVX2__)
  return traverse_wide<kAnyHit>(ray, setup, hit);
#endif

  const WatertightRay wray(ray);
  const KdNode* nodes = tree_.nodes.data();
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

    if (const std::uint32_t count = node.count(); count > 0) {
      const std::uint32_t first = node.prim_offset;
      if (intersect_leaf<kAnyHit>(wray, leaf_triangles_.leaf(first), ids + first, count, ray.tmin,
                                  ray.tmax, hit) &&
          kAnyHit)
        return true;
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

Hit KdAccel::closest_hit(const Ray& ray) const {
  Hit hit;
  if (!traverse<false>(ray, hit)) hit = Hit{};
  return hit;
}

bool KdAccel::any_hit(const Ray& ray) const {
  Hit unused;
  return traverse<true>(ray, unused);
}

void KdAccel::closest_hits(std::span<const Ray> rays, std::span<Hit> hits) const {
  if (hits.size() < rays.size()) throw Error("kd intersect", "fewer hit slots than rays");
  if (rays.size() > std::numeric_limits<std::uint32_t>::max())
    throw Error("kd intersect", "more than 2^32 - 1 rays in one call");
  parallel_chunks(rays.size(), 256, [&](std::size_t begin, std::size_t end) {
    // Coherent groups as packets (starting at multiples of the packet size, so the same
    // rays share a packet for any chunking); the other rays in interleaved single-ray walks.
    std::vector<std::uint32_t> rest;
    rest.reserve(end - begin);
    constexpr std::size_t kGroup = kPacketRays;
    for (std::size_t i = begin; i < end;) {
      const unsigned done = i % kGroup == 0 && i + kGroup <= end
                                ? intersect_packets(rays.data() + i, hits.data() + i)
                                : 0u;
      const std::size_t group_end = std::min(end, (i / kGroup + 1) * kGroup);
      for (; i < group_end; ++i)
        if (!(done >> ((i % kGroup) / 8) & 1)) rest.push_back(static_cast<std::uint32_t>(i));
    }
    walk_interleaved<false>(rays.data(), rest.data(), rest.size(), hits.data(), nullptr);
  });
}

void KdAccel::any_hits(std::span<const Ray> rays, std::span<std::uint8_t> result) const {
  if (result.size() < rays.size()) throw Error("kd occluded", "fewer result slots than rays");
  if (rays.size() > std::numeric_limits<std::uint32_t>::max())
    throw Error("kd occluded", "more than 2^32 - 1 rays in one call");
  parallel_chunks(rays.size(), 256, [&](std::size_t begin, std::size_t end) {
    std::vector<std::uint32_t> all(end - begin);
    for (std::size_t i = begin; i < end; ++i) all[i - begin] = static_cast<std::uint32_t>(i);
    walk_interleaved<true>(rays.data(), all.data(), all.size(), nullptr, result.data());
  });
}

}  // namespace splitray

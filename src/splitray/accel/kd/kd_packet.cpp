// Packets of 8 rays through the kd-tree (Wald 2004): one walk over the tree for rays that
// start close together and share their direction signs, such as primary rays of neighbouring
// pixels. Each ray keeps its own clipped interval, computed with the single-ray traversal's
// widening and the same float operations, enters a child exactly when the single-ray
// traversal would, tests the same leaves with the same exact triangle test and skips a far
// cell under the same rule, so every ray's hit is the one intersect(ray) returns.
#include <cmath>

#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/accel/kd/kd_ray_setup.hpp"
#include "splitray/accel/kd/kd_sah.hpp"

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace splitray {

#if defined(__AVX2__)

namespace {

constexpr int kLanes = 8;

struct PacketEntry {
  __m256 t0, t1;
  std::uint32_t node;
  unsigned mask;
};

}  // namespace

bool KdAccel::intersect_packet(const Ray* rays, Hit* hits) const {
  // Direction signs first (the inverse keeps the sign of each component, zeros included):
  // incoherent groups are turned away before any division.
  for (int l = 1; l < kLanes; ++l)
    for (int a = 0; a < 3; ++a)
      if (std::signbit(rays[l].dir[a]) != std::signbit(rays[0].dir[a])) return false;
  KdRaySetup setup[kLanes];
  unsigned active = 0;
  for (int l = 0; l < kLanes; ++l) {
    const Ray& ray = rays[l];
    if (!(ray.tmin <= ray.tmax) || !KdRaySetup::traversable(ray)) return false;
    setup[l] = KdRaySetup(ray, tree_.bounds, coord_scale_);
    for (int a = 0; a < 3; ++a)
      if ((setup[l].inv[a] < 0) != (setup[0].inv[a] < 0)) return false;
    if (setup[l].t0 <= setup[l].t1) active |= 1u << l;
  }

  alignas(32) float lane_org[3][kLanes], lane_inv[3][kLanes], lane_pad[3][kLanes];
  alignas(32) float lane_t0[kLanes], lane_t1[kLanes], hit_t[kLanes];
  Hit hit[kLanes];
  for (int l = 0; l < kLanes; ++l) {
    for (int a = 0; a < 3; ++a) {
      lane_org[a][l] = setup[l].org[a];
      lane_inv[a][l] = setup[l].inv[a];
      lane_pad[a][l] = setup[l].pad[a];
    }
    lane_t0[l] = setup[l].t0;
    lane_t1[l] = setup[l].t1;
    hit[l].t = hit_t[l] = rays[l].tmax;
  }
  __m256 org[3], inv[3], pad[3];
  bool below_first[3];
  for (int a = 0; a < 3; ++a) {
    org[a] = _mm256_load_ps(lane_org[a]);
    inv[a] = _mm256_load_ps(lane_inv[a]);
    pad[a] = _mm256_load_ps(lane_pad[a]);
    below_first[a] = !(setup[0].inv[a] < 0);
  }
  __m256 t0 = _mm256_load_ps(lane_t0), t1 = _mm256_load_ps(lane_t1);

  const KdNode* nodes = tree_.nodes.data();
  const std::uint32_t* ids = tree_.prim_ids.data();
  PacketEntry stack[kKdDepthLimit];
  int top = 0;
  std::uint32_t index = 0;
  while (active) {
    const KdNode node = nodes[index];
    if (!node.is_leaf()) {
      const int a = node.axis();
      // The single-ray step in every lane: t_split, its widened bounds, the children's ranges
      // (_mm256_min_ps(x, y) is x < y ? x : y, as the scalar code).
      const __m256 t_split =
          _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(node.split), org[a]), inv[a]);
      const __m256 hi = _mm256_add_ps(t_split, pad[a]), lo = _mm256_sub_ps(t_split, pad[a]);
      const __m256 first_t1 = _mm256_min_ps(hi, t1);
      const __m256 second_t0 = _mm256_max_ps(lo, t0);
      const unsigned enter_first =
          static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(t0, first_t1, _CMP_LE_OQ))) &
          active;
      const unsigned enter_second =
          static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(second_t0, t1, _CMP_LE_OQ))) &
          active;
      const std::uint32_t first = below_first[a] ? index + 1 : node.above();
      const std::uint32_t second = below_first[a] ? node.above() : index + 1;
      if (enter_first) {
        if (enter_second) stack[top++] = {second_t0, t1, second, enter_second};
        index = first;
        t1 = first_t1;
        active = enter_first;
        continue;
      }
      if (enter_second) {
        index = second;
        t0 = second_t0;
        active = enter_second;
        continue;
      }
    } else if (const std::uint32_t count = node.count(); count > 0) {
      const std::uint32_t begin = node.prim_offset;
      const float* rows = leaf_triangles_.leaf(begin);
      for (unsigned m = active; m; m &= m - 1) {
        const int l = __builtin_ctz(m);
        intersect_leaf<false>(WatertightRay(rays[l]), rows, ids + begin, count, rays[l].tmin,
                              rays[l].tmax, hit[l]);
        hit_t[l] = hit[l].t;
      }
    }
    // Next: the nearest pushed cell that some ray still needs (its entry t <= the ray's best).
    active = 0;
    while (top > 0) {
      const PacketEntry& entry = stack[--top];
      const __m256 best = _mm256_loadu_ps(hit_t);
      active =
          static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(entry.t0, best, _CMP_LE_OQ))) &
          entry.mask;
      if (active) {
        index = entry.node;
        t0 = entry.t0;
        t1 = entry.t1;
        break;
      }
    }
  }
  for (int l = 0; l < kLanes; ++l) hits[l] = hit[l].found() ? hit[l] : Hit{};
  return true;
}

#else

bool KdAccel::intersect_packet(const Ray*, Hit*) const { return false; }

#endif

}  // namespace splitray

// Packets of 8 rays through the kd-tree (Wald 2004): one walk over the tree for rays that
// start close together and share their direction signs, such as primary rays of neighbouring
// pixels. Each ray keeps its own clipped interval, computed with the single-ray traversal's
// widening and the same float operations, enters a child exactly when the single-ray
// traversal would, tests the same leaves with the same exact triangle test and skips a far
// cell under the same rule, so every ray's hit is the one intersect(ray) returns.
#include <cmath>
#include <limits>
#include <optional>

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
  for (int l = 0; l < kLanes; ++l)
    if (!(rays[l].tmin <= rays[l].tmax) || !KdRaySetup::traversable(rays[l])) return false;

  // KdRaySetup for the 8 rays at once: lane by lane the same float operations in the same
  // order (min/max and blends are exact; _mm256_min_ps(x, y) is x < y ? x : y, so
  // std::min(a, b) is _mm256_min_ps(b, a)), hence the same intervals as the single-ray call.
  alignas(32) float lane[8][kLanes];  // org xyz, dir xyz, tmin, tmax
  for (int l = 0; l < kLanes; ++l) {
    for (int a = 0; a < 3; ++a) lane[a][l] = rays[l].org[a], lane[3 + a][l] = rays[l].dir[a];
    lane[6][l] = rays[l].tmin;
    lane[7][l] = rays[l].tmax;
  }
  const __m256 sign_bit = _mm256_set1_ps(-0.0f);
  const auto fabs8 = [&](__m256 x) { return _mm256_andnot_ps(sign_bit, x); };
  __m256 org[3], dir[3], inv[3], pad[3];
  for (int a = 0; a < 3; ++a)
    org[a] = _mm256_load_ps(lane[a]), dir[a] = _mm256_load_ps(lane[3 + a]);
  const __m256 max_dir = _mm256_max_ps(_mm256_max_ps(fabs8(dir[2]), fabs8(dir[1])), fabs8(dir[0]));
  const __m256 tiny = _mm256_max_ps(_mm256_set1_ps(std::numeric_limits<float>::min()),
                                    _mm256_mul_ps(max_dir, _mm256_set1_ps(0x1p-40f)));
  __m256 far[3];
  for (int a = 0; a < 3; ++a) {
    const __m256 to_lo = fabs8(_mm256_sub_ps(org[a], _mm256_set1_ps(tree_.bounds.lo[a])));
    const __m256 to_hi = fabs8(_mm256_sub_ps(org[a], _mm256_set1_ps(tree_.bounds.hi[a])));
    far[a] = _mm256_max_ps(to_hi, to_lo);
  }
  const __m256 delta = _mm256_mul_ps(
      _mm256_set1_ps(0x1p-18f), _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(far[0], far[1]), far[2]),
                                              _mm256_set1_ps(coord_scale_)));
  const __m256 pad_t = _mm256_div_ps(delta, max_dir);
  __m256 t0 = _mm256_load_ps(lane[6]), t1 = _mm256_load_ps(lane[7]);
  bool below_first[3];
  for (int a = 0; a < 3; ++a) {
    const __m256 small = _mm256_cmp_ps(fabs8(dir[a]), tiny, _CMP_LT_OQ);
    const __m256 d =
        _mm256_blendv_ps(dir[a], _mm256_or_ps(tiny, _mm256_and_ps(sign_bit, dir[a])), small);
    inv[a] = _mm256_div_ps(_mm256_set1_ps(1.0f), d);
    pad[a] = _mm256_add_ps(_mm256_mul_ps(delta, fabs8(inv[a])), pad_t);
    const __m256 ta =
        _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(tree_.bounds.lo[a]), org[a]), inv[a]);
    const __m256 tb =
        _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(tree_.bounds.hi[a]), org[a]), inv[a]);
    const __m256 enter = _mm256_sub_ps(_mm256_min_ps(tb, ta), pad[a]);
    const __m256 leave = _mm256_add_ps(_mm256_max_ps(tb, ta), pad[a]);
    t0 = _mm256_max_ps(enter, t0);  // if (enter > t0) t0 = enter
    t1 = _mm256_min_ps(leave, t1);  // if (leave < t1) t1 = leave
    const unsigned negative = static_cast<unsigned>(
        _mm256_movemask_ps(_mm256_cmp_ps(inv[a], _mm256_setzero_ps(), _CMP_LT_OQ)));
    if (negative != 0 && negative != 0xffu) return false;
    below_first[a] = negative == 0;
  }
  unsigned active = static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(t0, t1, _CMP_LE_OQ)));
  alignas(32) float hit_t[kLanes];
  Hit hit[kLanes];
  for (int l = 0; l < kLanes; ++l) hit[l].t = hit_t[l] = rays[l].tmax;
  // The leaf test's per-ray constants, made when a ray first reaches a leaf.
  std::optional<WatertightRay> wray[kLanes];

  const KdNode* nodes = tree_.nodes.data();
  const std::uint32_t* ids = tree_.prim_ids.data();
  PacketEntry stack[kKdDepthLimit];
  int top = 0;
  std::uint32_t index = 0;
  while (active) {
    const KdNode node = nodes[index];
    if (!node.is_leaf()) {
      __builtin_prefetch(nodes + node.above());  // in case the packet goes there next
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
        if (!wray[l]) wray[l].emplace(rays[l]);
        intersect_leaf<false>(*wray[l], rows, ids + begin, count, rays[l].tmin, rays[l].tmax,
                              hit[l]);
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

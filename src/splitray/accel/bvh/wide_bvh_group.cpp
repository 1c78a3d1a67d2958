// Groups of rays that make no packet (wide_bvh_packet.cpp), in the batched calls: the root's
// slab test made for eight rays at once, a ray per 256-bit lane, then each ray walks alone from
// the children it entered (wide_bvh_walk.hpp). The root's test heads every ray's chain of
// dependent steps; made for eight independent rays together, the tests overlap, and each walk
// starts with the fetch of its first child: diffuse rays in batched calls 1.02-1.34 times as
// fast (docs/experiments.md, traversal round 9; Embree's rtcIntersect8 walks each such ray from
// the root, round 11). The rays' set-up is made in the same pass (GroupRays: the slab test's and
// the triangle test's constants, four divisions a ray alone), and each walk loads its lane's:
// another 1.03-1.12 times as fast (round 10). The same test in 512-bit lanes slowed the 256-bit
// walks around it on the Intel core it was measured on (every diffuse ray 15-25% slower), so
// the lanes are 256 bits.
#include "splitray/accel/bvh/wide_bvh.hpp"

#if defined(__AVX__) && defined(__FMA__)
#include <immintrin.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>

#include "splitray/accel/bvh/wide_bvh_walk.hpp"
#include "splitray/core/simd.hpp"

namespace splitray {

namespace {

using F8 = simd::Float8;
using wide_bvh::GroupRays;
using wide_bvh::kGroupLanes;

// The constants of up to eight rays (`n`; lanes beyond repeat the first ray) and their test of
// the root (GroupRays). Lane by lane these are the float operations of RobustRay, WatertightRay
// and WideSlab, so each ray enters the children its single-ray walk would, with the same entry
// parameters, and tests triangles with the same constants.
void group_rays(const WideNode& root, const Ray* rays, int n, const Aabb& scene, float magnitude,
                GroupRays& g) {
  static_assert(sizeof(Ray) == 8 * sizeof(float) && offsetof(Ray, tmax) == 7 * sizeof(float));
  // The rays' floats, field by field: an 8 x 8 transpose of the eight rays' rows.
  __m256 row[8], pair[8], quad[8];
  for (int r = 0; r < 8; ++r) row[r] = _mm256_loadu_ps(&rays[r < n ? r : 0].org.x);
  for (std::size_t k = 0; k < 4; ++k) {
    pair[2 * k] = _mm256_unpacklo_ps(row[2 * k], row[2 * k + 1]);
    pair[2 * k + 1] = _mm256_unpackhi_ps(row[2 * k], row[2 * k + 1]);
  }
  for (std::size_t k = 0; k < 2; ++k) {
    const __m256 *a = &pair[4 * k], *b = &pair[4 * k + 2];
    quad[4 * k] = _mm256_shuffle_ps(a[0], b[0], _MM_SHUFFLE(1, 0, 1, 0));
    quad[4 * k + 1] = _mm256_shuffle_ps(a[0], b[0], _MM_SHUFFLE(3, 2, 3, 2));
    quad[4 * k + 2] = _mm256_shuffle_ps(a[1], b[1], _MM_SHUFFLE(1, 0, 1, 0));
    quad[4 * k + 3] = _mm256_shuffle_ps(a[1], b[1], _MM_SHUFFLE(3, 2, 3, 2));
  }
  F8 field[8];
  for (std::size_t k = 0; k < 4; ++k) {
    field[k] = _mm256_permute2f128_ps(quad[k], quad[k + 4], 0x20);
    field[k + 4] = _mm256_permute2f128_ps(quad[k], quad[k + 4], 0x31);
  }
  const F8 org[3] = {field[0], field[1], field[2]};
  const F8 dir[3] = {field[3], field[4], field[5]};

  // RobustRay and WideSlab.
  const wide_bvh::SlabLanes<F8> slab = wide_bvh::slab_lanes(org, dir, scene, magnitude);
  simd::Mask8 inside{_mm256_castsi256_ps(_mm256_set1_epi32(-1))};
  for (int a = 0; a < 3; ++a) {
    slab.inv[a].store(g.inv[a]);
    slab.org_near[a].store(g.org_near[a]);
    slab.org_far[a].store(g.org_far[a]);
    g.negative[a] = static_cast<unsigned>(_mm256_movemask_ps(dir[a]));
    inside =
        inside & (F8::broadcast(scene.lo[a]) <= org[a]) & (org[a] <= F8::broadcast(scene.hi[a]));
  }
  g.inside = inside.bits();

  g.watertight = WatertightLanes<F8>(dir);

  // WideSlab::test of the root, a child at a time for all rays; each ray's sign bit picks its
  // planes.
  __m256i masks = _mm256_setzero_si256();
  for (int i = 0; i < kWideWidth; ++i) {
    F8 t0 = field[6], t1 = field[7];  // tmin, tmax
    for (int a = 0; a < 3; ++a) {
      const __m256 lo = _mm256_set1_ps(root.planes[a][i]);
      const __m256 hi = _mm256_set1_ps(root.planes[3 + a][i]);
      t0 = max(fmsub(_mm256_blendv_ps(lo, hi, dir[a].v), slab.inv[a], slab.org_near[a]), t0);
      t1 = min(fmsub(_mm256_blendv_ps(hi, lo, dir[a].v), slab.inv[a], slab.org_far[a]), t1);
    }
    t0.store(g.t_entry[i]);
    masks = _mm256_or_si256(
        masks, _mm256_and_si256(_mm256_castps_si256((t0 <= t1).m), _mm256_set1_epi32(1 << i)));
  }
  _mm256_store_si256(reinterpret_cast<__m256i*>(g.entered), masks);
}

// Each ray's answer as walk<AnyHit> gives it: `answer(r, result)` gets ray r's.
template <bool AnyHit, class Answer>
void walk_group(const WideNode* nodes, const TriangleBlock* blocks, std::span<const Ray> rays,
                const Aabb& scene, float magnitude, const Answer& answer) {
  for (std::size_t first = 0; first < rays.size(); first += kGroupLanes) {
    const std::span<const Ray> group =
        rays.subspan(first, std::min<std::size_t>(kGroupLanes, rays.size() - first));
    GroupRays g;
    group_rays(*nodes, group.data(), static_cast<int>(group.size()), scene, magnitude, g);
    for (std::size_t r = 0; r < group.size(); ++r) {
      Hit far_end;
      far_end.t = group[r].tmax;
      answer(first + r,
             wide_bvh::walk_in_group<AnyHit>(nodes, blocks, group[r], scene, magnitude, far_end,
                                             wide_bvh::FromGroup{g, static_cast<int>(r)}));
    }
  }
}

}  // namespace

bool WideBvh::intersect_group(std::span<const Ray> rays, const Aabb& scene, float magnitude,
                              Hit* hits) const {
  walk_group<false>(nodes_.data(), blocks_.data(), rays, scene, magnitude,
                    [&](std::size_t r, const Hit& hit) { hits[r] = hit; });
  return true;
}

bool WideBvh::occluded_group(std::span<const Ray> rays, const Aabb& scene, float magnitude,
                             std::uint8_t* occluded) const {
  walk_group<true>(nodes_.data(), blocks_.data(), rays, scene, magnitude,
                   [&](std::size_t r, bool hit) { occluded[r] = hit ? 1 : 0; });
  return true;
}

}  // namespace splitray

#else

namespace splitray {

bool WideBvh::intersect_group(std::span<const Ray>, const Aabb&, float, Hit*) const {
  return false;
}

bool WideBvh::occluded_group(std::span<const Ray>, const Aabb&, float, std::uint8_t*) const {
  return false;
}

}  // namespace splitray

#endif

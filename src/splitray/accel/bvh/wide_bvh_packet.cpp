// Packets of rays through the wide layout (wide_bvh.hpp), for the batched calls: sixteen rays
// with the same direction signs walk the tree together, one SIMD lane per ray (Wald,
// Slusallek, Benthin & Wagner 2001; Embree's packet traversal). A node's children are tested
// one at a time against all rays at once, so the node is fetched once and each box test costs
// the packet one vector step instead of each ray a share of its own 16-lane test. Every lane
// computes its ray's slab test with the single-ray walk's float operations
// (wide_bvh_walk.hpp), keeps its own closest hit and skips a child under the same rule. A leaf
// is tested ray by ray (a block of eight triangles per test) or, when that makes fewer tests and
// the rays share the watertight test's axis order, triangle by triangle against all its rays
// (core/triangle_simd.hpp); both make each lane's float operations of the same watertight test,
// so each ray's answer is the one intersect(ray) gives. A child is entered for the rays whose
// box tests passed, nearest first for the packet (by the least entry distance among them).
#include "splitray/accel/bvh/wide_bvh.hpp"

#if defined(__AVX512F__)
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstddef>
#include <new>
#include <optional>
#include <type_traits>

#include "splitray/accel/bvh/wide_bvh_walk.hpp"
#include "splitray/accel/traversal_stack.hpp"
#include "splitray/core/simd.hpp"
#include "splitray/core/triangle_simd.hpp"

namespace splitray {

namespace {

using wide_bvh::prefetch;
using wide_bvh::test_leaf;
using wide_bvh::WatertightBlock;

using F = simd::Float16;  // a lane per ray
constexpr int kLanes = WideBvh::kPacketRays;
static_assert(kLanes == F::kLanes);

struct Entry {
  std::uint32_t child;
  std::uint32_t count;  // 0: a wide node
  std::uint32_t rays;   // the packet's rays that entered it (bit per ray)
  float t0;             // the least entry distance among them
};

// A packet's rays read a lane each: float f of each ray (the Ray's floats in order), 1 in the
// lanes beyond the rays given.
class PacketLoad {
 public:
  PacketLoad(const Ray* rays, int n)
      : base_(&rays[0].org.x),
        lanes_(static_cast<__mmask16>(n == kLanes ? 0xffffu : (1u << n) - 1)) {}
  F field(int f) const {
    static_assert(sizeof(Ray) == 8 * sizeof(float) && offsetof(Ray, tmax) == 7 * sizeof(float));
    const __m512i index = _mm512_add_epi32(
        _mm512_mullo_epi32(_mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15),
                           _mm512_set1_epi32(8)),
        _mm512_set1_epi32(f));
    return _mm512_mask_i32gather_ps(_mm512_set1_ps(1.0f), lanes_, index, base_, 4);
  }
  __mmask16 lanes() const { return lanes_; }

 private:
  const float* base_;
  __mmask16 lanes_;
};

// Whether the rays walk the tree well together: the same direction signs (so the same near and
// far box planes, the packet's precondition) and, unless `any_angle`, directions within about
// 10 degrees of the first's, as neighbouring primary rays (16 pixels of a 256-pixel row span 4
// degrees of a 60-degree view) or shadow rays towards one light. Diverging rays (diffuse
// bounces) would each pay for the nodes the others enter; their signs turn them away ray by
// ray, mostly at the second, before any SIMD work. Rays from neighbouring origins spread over
// 25 degrees (the bound before) walked 9-14% slower as packets than alone.
bool coherent(const Ray* rays, int n, const PacketLoad& load, bool any_angle) {
  const auto signs = [](const Vec3& d) {
    return static_cast<int>(std::signbit(d.x)) | static_cast<int>(std::signbit(d.y)) << 1 |
           static_cast<int>(std::signbit(d.z)) << 2;
  };
  const Vec3 first = rays[0].dir;
  const int first_signs = signs(first);
  for (int r = 1; r < n; ++r)
    if (signs(rays[r].dir) != first_signs) return false;
  if (any_angle) return true;
  F dot_first = F::zero(), length_squared = F::zero();
  for (int a = 0; a < 3; ++a) {
    const F dir = load.field(3 + a);
    dot_first = dot_first + dir * F::broadcast(first[a]);
    length_squared = length_squared + dir * dir;
  }
  // (The zero-masked sqrt: GCC 12 warns that the plain one's undefined source may be unset.)
  const F length = _mm512_maskz_sqrt_ps(0xffff, length_squared);
  const F bound = F::broadcast(0.985f) * length * F::broadcast(splitray::length(first));
  return ((dot_first >= bound).bits() & load.lanes()) == load.lanes();
}

// The slab test's constants of a packet's rays, a lane each: RobustRay's float operations lane
// by lane (so each equals the single-ray walk's), for all rays in one pass instead of ray by
// ray (on the Cornell box, a third of a packet's time went to making them one at a time).
struct PacketRays {
  wide_bvh::SlabLanes<F> slab;  // RobustRay's inv, org_near * inv, org_far * inv
  F tmin, tmax;
  std::optional<WatertightPacket> triangles;  // when the rays share the test's axis order
};

PacketRays packet_constants(const PacketLoad& load, const Aabb& scene, float magnitude) {
  const F org[3] = {load.field(0), load.field(1), load.field(2)};
  const F dir[3] = {load.field(3), load.field(4), load.field(5)};
  PacketRays p{wide_bvh::slab_lanes(org, dir, scene, magnitude), load.field(6), load.field(7), {}};
  int k[3];
  if (WatertightPacket::shared_axes(dir, load.lanes(), k)) p.triangles.emplace(org, dir, k);
  return p;
}

// The triangle test's constants of one ray, made at its first leaf (as the single-ray walk).
struct LeafRay {
  WatertightRay w;
  WatertightBlock wb;
  explicit LeafRay(const Ray& ray) : w(ray), wb(w) {}
};

// The packet's LeafRays, left unset until a ray reaches its first leaf (sixteen empty
// std::optionals were cleared by a memset of 4 KB per packet: 7% of the Cornell box's time).
class LeafRays {
 public:
  LeafRays() {}  // NOLINT(modernize-use-equals-default): `= default` would clear the slots
  const LeafRay& of(int r, const Ray& ray) {
    if ((made_ >> r & 1u) == 0) {
      new (&slots_[r].ray) LeafRay(ray);
      made_ |= 1u << r;
    }
    return slots_[r].ray;
  }

 private:
  union Slot {
    Slot() {}  // NOLINT(modernize-use-equals-default): unset
    LeafRay ray;
  };
  static_assert(std::is_trivially_destructible_v<LeafRay>);
  Slot slots_[kLanes];
  unsigned made_ = 0;
};

// The lanes of a leaf's last block that hold distinct triangles (the rest repeat the last one),
// without a loop: its trip count was a mispredicted branch at every leaf a packet entered
// (batched primary rays 2-4% slower on the dragon, samba and the cat).
int distinct_lanes(const TriangleBlock& block) {
  const __m256i ids = _mm256_load_si256(reinterpret_cast<const __m256i*>(block.id));
  const __m256i last = _mm256_set1_epi32(static_cast<int>(block.id[kBlockWidth - 1]));
  const unsigned repeats =
      static_cast<unsigned>(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(ids, last))));
  // The trailing run of lanes equal to the last, the last included.
  return kBlockWidth + 1 - std::countl_one(static_cast<std::uint8_t>(repeats));
}

// Whether a leaf's triangles are tested one at a time against the rays that entered it (a
// 16-lane test per triangle) rather than ray by ray (an 8-lane test per block): whichever makes
// fewer tests. (Choosing the first from 0.75, 1.5 or 2 times as many tests measured the same or
// slower; so did an 8-lane test for leaves entered by at most eight rays.)
// `last_lanes` gets the distinct triangles of the leaf's last block.
bool transposed(const Entry& leaf, const TriangleBlock* blocks, int& last_lanes) {
  last_lanes = distinct_lanes(blocks[leaf.child + leaf.count - 1]);
  const int triangles = static_cast<int>(leaf.count - 1) * kBlockWidth + last_lanes;
  return triangles <= std::popcount(leaf.rays) * static_cast<int>(leaf.count);
}

template <bool AnyHit>
unsigned traverse_packet(std::span<const WideNode> node_span,
                         std::span<const TriangleBlock> block_span, const Ray* rays, int n,
                         const PacketRays& p, Hit* best) {
  const WideNode* const nodes = node_span.data();
  const TriangleBlock* const blocks = block_span.data();
  int near[3], far[3];
  for (int a = 0; a < 3; ++a) {  // every ray of a packet has these signs (coherent() checks)
    const bool negative = std::signbit(rays[0].dir[a]);
    near[a] = negative ? 3 + a : a;
    far[a] = negative ? a : 3 + a;
  }
  const F* const v_org_near = p.slab.org_near;
  const F* const v_org_far = p.slab.org_far;
  const F* const v_inv = p.slab.inv;
  const F v_tmin = p.tmin;
  alignas(64) float tmin[kLanes], tmax[kLanes];
  v_tmin.store(tmin);
  p.tmax.store(tmax);
  for (int r = 0; r < n; ++r) best[r] = Hit{tmax[r]};
  F v_best = p.tmax;  // lane r: best[r].t
  LeafRays leaf_rays;

  const unsigned all = n == kLanes ? 0xffffu : (1u << n) - 1;
  unsigned live = all;  // any hit: the rays not yet occluded
  TraversalStack<Entry, wide_bvh::kStackSize> stack;
  Entry current{0, 0, live, 0};
  for (;;) {
    if (current.count == 0) {  // a wide node: each used child against every ray
      const WideNode& node = nodes[current.child];
      const simd::Mask16 rays_in{static_cast<__mmask16>(current.rays)};
      using Slots = wide_bvh::WideSlab::Lanes;  // a lane per child
      const unsigned used = (Slots::load(node.planes[0]) <= Slots::load(node.planes[3])).bits();
      Entry nearest{0, 0, 0, kInfinity};
      const int mark = stack.size();
      for (unsigned m = used; m != 0; m &= m - 1) {
        const int c = std::countr_zero(m);
        F t0 = v_tmin, t1 = v_best;
        for (int a = 0; a < 3; ++a) {  // NaN in the first operand keeps t0, t1
          t0 = max(fmsub(F::broadcast(node.planes[near[a]][c]), v_inv[a], v_org_near[a]), t0);
          t1 = min(fmsub(F::broadcast(node.planes[far[a]][c]), v_inv[a], v_org_far[a]), t1);
        }
        const simd::Mask16 entering = (t0 <= t1) & rays_in;
        const unsigned enter = entering.bits();
        if (enter == 0) continue;
        if (node.count[c] == 0)
          prefetch<sizeof(WideNode)>(&nodes[node.child[c]]);
        else
          prefetch<sizeof(TriangleBlock)>(&blocks[node.child[c]]);
        Entry e{node.child[c], node.count[c], enter, min_of(t0, entering)};
        if (nearest.rays == 0) {
          nearest = e;
          continue;
        }
        if (e.t0 < nearest.t0) std::swap(e, nearest);
        stack.push_ordered(e, mark);
      }
      if (nearest.rays != 0) {
        current = nearest;
        continue;
      }
    } else if (int last_lanes = 0; p.triangles && transposed(current, blocks, last_lanes)) {
      // a leaf entered by many rays: its triangles one at a time against all of them
      const unsigned rays_in = current.rays & live;
      for (std::uint32_t b = 0; b < current.count; ++b) {
        const TriangleBlock& block = blocks[current.child + b];
        const int lanes = b + 1 < current.count ? kBlockWidth : last_lanes;
        for (int lane = 0; lane < lanes; ++lane) {
          alignas(64) float t[kLanes], u[kLanes], v[kLanes];
          unsigned scalar;
          const auto coordinate = [&](int vertex, int axis) {
            return block.v[3 * vertex + axis][lane];
          };
          unsigned found =
              p.triangles->test(coordinate, rays_in & live, v_tmin, v_best, t, u, v, scalar);
          while (scalar != 0) {  // edge cases: the scalar test decides in double precision
            const int r = std::countr_zero(scalar);
            scalar &= scalar - 1;
            if (intersect_triangle(leaf_rays.of(r, rays[r]).w, block.triangle(lane), tmin[r],
                                   best[r].t, t[r], u[r], v[r]))
              found |= 1u << r;
          }
          if (found == 0) continue;
          if constexpr (AnyHit) {
            live &= ~found;
          } else {
            for (unsigned m = found; m != 0; m &= m - 1) {
              const int r = std::countr_zero(m);
              const Hit candidate{t[r], block.id[lane], u[r], v[r]};
              if (candidate.closer_than(best[r])) best[r] = candidate;
              tmax[r] = best[r].t;
            }
            v_best = F::load(tmax);
          }
        }
      }
      if (AnyHit && live == 0) return all;
    } else {  // a leaf: its blocks, ray by ray
      for (unsigned m = current.rays; m != 0; m &= m - 1) {
        const int r = std::countr_zero(m);
        const LeafRay& lr = leaf_rays.of(r, rays[r]);
        if (test_leaf<AnyHit>(blocks + current.child, current.count, lr.w, lr.wb, tmin[r],
                              best[r]) &&
            AnyHit)
          live &= ~(1u << r);
        tmax[r] = best[r].t;
      }
      if (AnyHit && live == 0) return all;
      v_best = F::load(tmax);
    }
    // The next entry with a ray whose closest hit is not in front of it (the culled pop, ray
    // by ray: a lane keeps the entry while its t0 <= the lane's closest t).
    unsigned keep = 0;
    const Entry* next = stack.pop_until([&](const Entry& e) {
      keep = ((F::broadcast(e.t0) <= v_best) & simd::Mask16{static_cast<__mmask16>(e.rays & live)})
                 .bits();
      return keep != 0;
    });
    if (!next) return all & ~live;
    current = *next;
    current.rays = keep;
  }
}

}  // namespace

bool WideBvh::intersect_packet(std::span<const Ray> rays, const Aabb& scene, float magnitude,
                               Hit* hits, bool any_angle) const {
  const int n = static_cast<int>(rays.size());
  const PacketLoad load(rays.data(), n);
  if (!coherent(rays.data(), n, load, any_angle)) return false;
  traverse_packet<false>(nodes_, blocks_, rays.data(), n, packet_constants(load, scene, magnitude),
                         hits);
  return true;
}

std::optional<unsigned> WideBvh::occluded_packet(std::span<const Ray> rays, const Aabb& scene,
                                                 float magnitude, bool any_angle) const {
  const int n = static_cast<int>(rays.size());
  const PacketLoad load(rays.data(), n);
  if (!coherent(rays.data(), n, load, any_angle)) return std::nullopt;
  Hit unused[kPacketRays];
  return traverse_packet<true>(nodes_, blocks_, rays.data(), n,
                               packet_constants(load, scene, magnitude), unused);
}

}  // namespace splitray

#else

namespace splitray {

bool WideBvh::intersect_packet(std::span<const Ray>, const Aabb&, float, Hit*, bool) const {
  return false;
}

std::optional<unsigned> WideBvh::occluded_packet(std::span<const Ray>, const Aabb&, float,
                                                 bool) const {
  return std::nullopt;
}

}  // namespace splitray

#endif

#pragma once
// One ray against the wide layout (wide_bvh.hpp): its node and block tests and its walk, used
// by the single-ray calls (wide_bvh_traverse.cpp); the packets (wide_bvh_packet.cpp) repeat the
// node test lane by lane and share the block test, so a ray enters the same children and tests
// the same triangles in both. The slab test of the SIMD paths (with FMA) and of the scalar path
// round differently, but both stay within the padding of robust_ray.hpp (min/max operand order
// keeps NaN out), so both let every ray through to every triangle it may hit, and the answers
// come from the same watertight triangle test.
#if defined(__SSE__)
#include <immintrin.h>
#endif

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <type_traits>

#include "splitray/accel/bvh/wide_bvh.hpp"
#include "splitray/accel/robust_ray.hpp"
#include "splitray/accel/traversal_stack.hpp"
#include "splitray/core/simd.hpp"
#include "splitray/core/triangle_simd.hpp"

namespace splitray::wide_bvh {

#if defined(__AVX__) && defined(__FMA__)
constexpr int kGroupLanes = 8;

// The constants of a group of up to eight rays that make no packet (wide_bvh_group.cpp), a
// lane each, made for all of them at once with the float operations that RobustRay,
// WatertightRay and WideSlab make for one ray, so each ray's walk reads what it would have made
// (and tests the same boxes and triangles); and the root's slab test, made for all of them.
struct GroupRays {
  alignas(32) float inv[3][kGroupLanes];               // WideSlab's inv
  alignas(32) float org_near[3][kGroupLanes];          // WideSlab's org_near (times inv)
  alignas(32) float org_far[3][kGroupLanes];           // WideSlab's org_far (times inv)
  alignas(32) float t_entry[kWideWidth][kGroupLanes];  // the root's children: entry parameters
  alignas(32) std::uint32_t entered[kGroupLanes];      // and the children each ray enters
  WatertightLanes<simd::Float8> watertight;
  // A bit per lane: the direction's sign along each axis (RobustRay's negative); starts_inside.
  unsigned negative[3], inside;
};
#endif

// The per-ray constants of the wide slab test: plane rows by direction sign, and the origins
// times the inverse direction and the inverse broadcast once. A plane's parameter is
// plane * inv - org * inv in one rounding (fmsub): the extra error of rounding org * inv is below
// 2^-24 |org inv|, 1/64 of the padding (robust_ray.hpp), so the test stays conservative. No
// parameter is NaN: the inverse is finite (RobustRay makes a zero component tiny) and an empty
// slot's planes are +-inf; max and min keep their second operand should one be.
#if defined(__AVX512F__) || (defined(__AVX__) && defined(__FMA__))
struct WideSlab {
  // One lane per child of a node (the packets load a node's rows with it too).
#if defined(__AVX512F__)
  using Lanes = std::conditional_t<kWideWidth == 16, simd::Float16, simd::Float8>;
#else
  using Lanes = simd::Float8;
#endif
  static_assert(Lanes::kLanes == kWideWidth);
  int near[3], far[3];
  Lanes org_near[3], org_far[3], inv[3];

  explicit WideSlab(const RobustRay& r) {
    for (int a = 0; a < 3; ++a) {
      near[a] = a + 3 * r.negative[a];  // arithmetic, not a branch on the ray's signs
      far[a] = a + 3 - 3 * r.negative[a];
      org_near[a] = Lanes::broadcast(r.org_near[a] * r.inv[a]);
      org_far[a] = Lanes::broadcast(r.org_far[a] * r.inv[a]);
      inv[a] = Lanes::broadcast(r.inv[a]);
    }
  }
#if defined(__AVX__) && defined(__FMA__)
  // Ray `lane` of a group: loads, where the ray alone makes a division and nine products.
  WideSlab(const GroupRays& g, int lane) {
    for (int a = 0; a < 3; ++a) {
      const int negative = static_cast<int>(g.negative[a] >> lane & 1u);
      near[a] = a + 3 * negative;
      far[a] = a + 3 - 3 * negative;
      org_near[a] = Lanes::broadcast(g.org_near[a][lane]);
      org_far[a] = Lanes::broadcast(g.org_far[a][lane]);
      inv[a] = Lanes::broadcast(g.inv[a][lane]);
    }
  }
#endif

  // Entry parameters into all slots (within [tmin, tmax]); bit i set on a hit.
  unsigned test(const WideNode& n, float tmin, float tmax, float* t_entry) const {
    Lanes t0 = Lanes::broadcast(tmin), t1 = Lanes::broadcast(tmax);
    for (int a = 0; a < 3; ++a) {
      t0 = max(fmsub(Lanes::load(n.planes[near[a]]), inv[a], org_near[a]), t0);
      t1 = min(fmsub(Lanes::load(n.planes[far[a]]), inv[a], org_far[a]), t1);
    }
    t0.store(t_entry);
    return (t0 <= t1).bits();
  }
};
#else
struct WideSlab {  // the portable build: one slot at a time
  int near[3], far[3];
  RobustRay r;

  explicit WideSlab(const RobustRay& ray) : r(ray) {
    for (int a = 0; a < 3; ++a) {
      near[a] = r.negative[a] ? 3 + a : a;
      far[a] = r.negative[a] ? a : 3 + a;
    }
  }

  unsigned test(const WideNode& n, float tmin, float tmax, float* t_entry) const {
    unsigned mask = 0;
    for (int i = 0; i < kWideWidth; ++i) {
      float t0 = tmin, t1 = tmax;
      for (int a = 0; a < 3; ++a) {
        t0 = max_keep(t0, (n.planes[near[a]][i] - r.org_near[a]) * r.inv[a]);
        t1 = min_keep(t1, (n.planes[far[a]][i] - r.org_far[a]) * r.inv[a]);
      }
      t_entry[i] = t0;
      if (t0 <= t1) mask |= 1u << i;
    }
    return mask;
  }
};
#endif

#if defined(__AVX__)
// The slab test's constants of several rays, a SIMD lane each (F: simd::Float8 or Float16):
// RobustRay's float operations lane by lane, so each lane holds what WideSlab holds for its
// ray (the inverse direction, and the origin moved by -+delta times it). Shared by the packets
// (wide_bvh_packet.cpp) and the groups' test of the root (wide_bvh_group.cpp).
template <class F>
struct SlabLanes {
  F inv[3], org_near[3], org_far[3];
};

template <class F>
SlabLanes<F> slab_lanes(const F (&org)[3], const F (&dir)[3], const Aabb& scene, float magnitude) {
  const F max_dir = max(abs(dir[0]), max(abs(dir[1]), abs(dir[2])));
  const F tiny =
      max(max_dir * F::broadcast(0x1p-40f), F::broadcast(std::numeric_limits<float>::min()));
  F far[3];
  for (int a = 0; a < 3; ++a)
    far[a] = max(abs(org[a] - F::broadcast(scene.lo[a])), abs(org[a] - F::broadcast(scene.hi[a])));
  const F delta = F::broadcast(0x1p-18f) * (((far[0] + far[1]) + far[2]) + F::broadcast(magnitude));
  SlabLanes<F> s;
  for (int a = 0; a < 3; ++a) {
    const F safe = select(abs(dir[a]) < tiny, with_sign(tiny, dir[a]), dir[a]);
    const F step = with_sign(delta, dir[a]);  // +-delta by the direction's sign
    s.inv[a] = F::broadcast(1.0f) / safe;
    s.org_near[a] = (org[a] + step) * s.inv[a];
    s.org_far[a] = (org[a] - step) * s.inv[a];
  }
  return s;
}
#endif

// Asks for the cache lines of a node, or of a leaf's first block, before they are needed.
template <std::size_t kBytes>
inline void prefetch(const void* p) {
#if defined(__SSE__)
  const char* c = static_cast<const char*>(p);
  for (std::size_t line = 0; line < kBytes; line += 64) _mm_prefetch(c + line, _MM_HINT_T0);
#else
  (void)p;
#endif
}

// The eight triangles of a block through the 8-wide watertight test (core/triangle_simd.hpp);
// the lanes it hands back, and without AVX every lane, go to the scalar test (the portable
// build tests one triangle at a time).
struct WatertightBlock {
#if defined(__AVX__)
  Watertight8 test8;
  explicit WatertightBlock(const WatertightRay& ray) : test8(ray) {}
  template <bool kEarlyOuts = true>
  unsigned test(const TriangleBlock& b, float tmin, float tmax, float* t_out, float* u_out,
                float* v_out, unsigned& scalar) const {
    const auto load = [&](int vertex, int axis) { return _mm256_load_ps(b.v[3 * vertex + axis]); };
    return test8.template test<kEarlyOuts>(load, (1u << kBlockWidth) - 1, tmin, tmax, t_out, u_out,
                                           v_out, scalar);
  }
#else
  explicit WatertightBlock(const WatertightRay&) {}
  template <bool kEarlyOuts = true>
  unsigned test(const TriangleBlock&, float, float, float*, float*, float*,
                unsigned& scalar) const {
    scalar = (1u << kBlockWidth) - 1;
    return 0;
  }
#endif
};

// Tests the `count` blocks of a leaf for one ray with t in [tmin, best.t]. Closest hit: `best`
// becomes the closest hit under the tie rule of Hit; any hit: true at the first hit.
// kEarlyOuts: each block test returns once no triangle is left (see walk).
template <bool AnyHit, bool kEarlyOuts = true>
[[gnu::always_inline]] inline bool test_leaf(const TriangleBlock* blocks, std::uint32_t count,
                                             const WatertightRay& w, const WatertightBlock& wb,
                                             float tmin, Hit& best) {
  for (std::uint32_t b = 0; b < count; ++b) {
    alignas(32) float t[kBlockWidth], u[kBlockWidth], v[kBlockWidth];
    unsigned scalar;
    const TriangleBlock& block = blocks[b];
    unsigned found = wb.template test<kEarlyOuts>(block, tmin, best.t, t, u, v, scalar);
    while (scalar != 0) {  // edge cases: the scalar test decides in double precision
      const int lane = std::countr_zero(scalar);
      scalar &= scalar - 1;
      if (intersect_triangle(w, block.triangle(lane), tmin, best.t, t[lane], u[lane], v[lane]))
        found |= 1u << lane;
    }
    if constexpr (AnyHit) {
      if (found != 0) return true;
    } else {
      while (found != 0) {
        const int lane = std::countr_zero(found);
        found &= found - 1;
        const Hit candidate{t[lane], block.id[lane], u[lane], v[lane]};
        if (candidate.closer_than(best)) best = candidate;
      }
    }
  }
  return false;
}

constexpr int kStackSize = kWideWidth * 64;  // fewer than kWideWidth pushes per level, 64 levels

struct Entry {
  std::uint32_t child;
  std::uint32_t count;  // 0: a wide node
  float t0;             // where the ray enters it
};

// What the plain walk counts: nothing (every call compiles away).
struct NoCounts {
  void node(const WideNode&) {}
  void leaf(const TriangleBlock*, std::uint32_t, const Hit&) {}
};

// What the counting walk adds up for the benchmark's profile (bench/bvh_bench.cpp); `closest`
// is the ray's answer, found by a plain walk first.
struct Counting {
  WideBvhCounts& c;
  Hit closest;
  void node(const WideNode& n) {
    ++c.nodes;
    for (int i = 0; i < kWideWidth; ++i) c.boxes += n.planes[0][i] <= n.planes[3][i] ? 1 : 0;
  }
  // A leaf of `count` blocks entered with `best` the closest hit so far.
  void leaf(const TriangleBlock* blocks, std::uint32_t count, const Hit& best) {
    ++c.leaves;
    c.blocks += count;
    if (!closest.found()) return;
    if (best.prim == closest.prim && best.t == closest.t) ++c.late_leaves;
    bool holds = false;
    for (std::uint32_t b = 0; b < count; ++b)
      for (const std::uint32_t id : blocks[b].id) holds |= id == closest.prim;
    c.hit_leaves += holds ? 1 : 0;
  }
};

// Where a walk starts, and where its ray's constants come from. From the root: the constants
// are made in the walk, not passed in, because a RobustRay built by the caller is read back from
// memory (single primary rays were 6-7% slower that way, AMD EPYC).
struct FromRoot {
  static constexpr bool kRootTested = false;
  static WideSlab slab(const Ray& ray, const Aabb& scene, float magnitude) {
    return WideSlab(RobustRay(ray, scene, magnitude));
  }
  static WatertightRay watertight(const Ray& ray) { return WatertightRay(ray); }
};

#if defined(__AVX__) && defined(__FMA__)
// From the children that ray `lane` of a group enters, its constants read from the group's.
struct FromGroup {
  static constexpr bool kRootTested = true;
  const GroupRays& g;
  int lane;
  WideSlab slab(const Ray&, const Aabb&, float) const { return WideSlab(g, lane); }
  WatertightRay watertight(const Ray& ray) const { return g.watertight.ray(lane, ray.org); }
  unsigned entered() const { return g.entered[lane]; }
  const float* t_entry() const { return &g.t_entry[0][lane]; }  // child i's at [i * kStride]
  static constexpr std::ptrdiff_t kStride = kGroupLanes;
};
#endif

// One ray's walk, in one loop whose state (ray constants, current entry, stack, closest hit)
// lives in locals the compiler keeps in registers. Children hit by the ray are entered nearest
// first; the others wait on the stack, farther ones lower, and are skipped once behind the
// closest hit. `best` is the closest hit so far (t = tmax when none); returns the closest hit,
// or for an any-hit query whether there is one. The hit goes back by value, in registers:
// through a Hit& the caller reloaded t and prim as one 8-byte word written by two 4-byte
// stores, which the CPU cannot forward, a stall on every ray (single rays that miss the mesh
// took 17 ns, 3 of them there). kInside: the ray starts inside the scene's box (see walk).
// `start`: FromRoot or FromGroup.
template <bool AnyHit>
using WalkResult = std::conditional_t<AnyHit, bool, Hit>;

template <bool AnyHit, bool kInside, class Start, class Counts>
WalkResult<AnyHit> walk_from(const WideNode* nodes, const TriangleBlock* blocks, const Ray& ray,
                             const Aabb& scene, float magnitude, Hit best, Counts counts,
                             const Start& start) {
  const WideSlab slab = start.slab(ray, scene, magnitude);
  std::optional<WatertightRay> w;  // the triangle test's constants (three divisions)
  std::optional<WatertightBlock> wb;
  if constexpr (kInside) wb.emplace(w.emplace(start.watertight(ray)));
  const float tmin = ray.tmin;  // best.t: the far end of every test (tmax for an any-hit query)
  TraversalStack<Entry, kStackSize> stack;
  Entry current{0, 0, 0};  // the root
  // Enters the nearest of the children of `n` in `mask` (entry parameters t[i * stride]) and
  // pushes the others. Most nodes are entered through one or two children: those take no loop,
  // because the walk's time goes mostly to mispredicted branches (diffuse rays through the
  // faerie took 2.2 times as long as the same rays repeated, whose branches the CPU learns),
  // and a loop's exit is one more. Each child is asked for as it is taken, so the memory loads
  // overlap instead of waiting for each other. (Forcing the two `? :` below into masks or SSE
  // blends measured level.)
  const auto descend = [&](const WideNode& n, unsigned mask, const float* t,
                           std::ptrdiff_t stride) {
    const auto enter = [&](unsigned& m) {
      const int i = std::countr_zero(m);
      m &= m - 1;
      const Entry e{n.child[i], n.count[i], t[static_cast<std::ptrdiff_t>(i) * stride]};
      const char* node = reinterpret_cast<const char*>(nodes + e.child);
      const char* block = reinterpret_cast<const char*>(blocks + e.child);
      prefetch<std::max(sizeof(WideNode), sizeof(TriangleBlock))>(e.count == 0 ? node : block);
      return e;
    };
    Entry nearest = enter(mask);
    if (mask != 0) {
      const Entry second = enter(mask);
      const bool closer = second.t0 < nearest.t0;
      const Entry farther = closer ? nearest : second;
      nearest = closer ? second : nearest;
      const int mark = stack.size();
      stack.push(farther);
      while (mask != 0) {  // three or more: the others in order on the stack
        Entry e = enter(mask);
        if (e.t0 < nearest.t0) std::swap(e, nearest);
        stack.push_ordered(e, mark);
      }
    }
    current = nearest;
  };
  if constexpr (Start::kRootTested) {
    if (start.entered() == 0) {
      if constexpr (AnyHit)
        return false;
      else
        return best;
    }
    descend(nodes[0], start.entered(), start.t_entry(), Start::kStride);
  }
  for (;;) {
    if (current.count == 0) {  // a wide node: enter the nearest hit child, push the others
      const WideNode& n = nodes[current.child];
      counts.node(n);
      alignas(64) float t_entry[kWideWidth];
      const unsigned mask = slab.test(n, tmin, best.t, t_entry);
      if (mask != 0) {
        descend(n, mask, t_entry, 1);
        continue;
      }
    } else {  // a leaf: its blocks of eight triangles
      if (!kInside && !wb) wb.emplace(w.emplace(start.watertight(ray)));
      counts.leaf(blocks + current.child, current.count, best);
      const bool found =
          test_leaf<AnyHit, !kInside>(blocks + current.child, current.count, *w, *wb, tmin, best);
      if constexpr (AnyHit)
        if (found) return true;
    }
    const Entry* next = stack.pop_not_behind(best.t);
    if (!next) {
      if constexpr (AnyHit)
        return false;
      else
        return best;
    }
    current = *next;
  }
}

// The walk of a ray, in one of two forms by where it starts (starts_inside, robust_ray.hpp).
// A ray that starts inside the scene's box (a ray leaving a surface, a camera in a room) gets its
// triangle-test constants at once, so that their latency overlaps the first nodes' (it reaches
// at least the leaf it starts in: diffuse rays 0-4% faster), and tests blocks without early outs:
// whether any of a block's eight triangles is left after the edge tests is a coin toss for such
// rays, which the branch predictor does not learn, and the mispredictions cost more than the rest
// of the test (diffuse rays 2-3% faster, docs/experiments.md traversal round 7). A ray from a
// camera outside gets its constants at its first leaf, as many such rays miss everything (made at
// once, primary rays 5% slower), and keeps the early outs, which neighbouring rays take alike
// (without them primary rays were 9% slower).
template <bool AnyHit, class Counts = NoCounts>
WalkResult<AnyHit> walk(const WideNode* nodes, const TriangleBlock* blocks, const Ray& ray,
                        const Aabb& scene, float magnitude, Hit best, Counts counts = {}) {
  return starts_inside(ray, scene) ? walk_from<AnyHit, true>(nodes, blocks, ray, scene, magnitude,
                                                             best, counts, FromRoot{})
                                   : walk_from<AnyHit, false>(nodes, blocks, ray, scene, magnitude,
                                                              best, counts, FromRoot{});
}

#if defined(__AVX__) && defined(__FMA__)
// The same walk for ray `start.lane` of a group (wide_bvh_group.cpp).
template <bool AnyHit>
WalkResult<AnyHit> walk_in_group(const WideNode* nodes, const TriangleBlock* blocks, const Ray& ray,
                                 const Aabb& scene, float magnitude, Hit best,
                                 const FromGroup& start) {
  return (start.g.inside >> start.lane & 1u) != 0
             ? walk_from<AnyHit, true>(nodes, blocks, ray, scene, magnitude, best, NoCounts{},
                                       start)
             : walk_from<AnyHit, false>(nodes, blocks, ray, scene, magnitude, best, NoCounts{},
                                        start);
}
#endif

}  // namespace splitray::wide_bvh

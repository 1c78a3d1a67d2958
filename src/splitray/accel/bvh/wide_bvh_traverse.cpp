// Traversing the wide layout (wide_bvh.hpp) one ray at a time, with the node and block tests
// of wide_bvh_tests.hpp.
#include <algorithm>
#include <bit>
#include <limits>
#include <optional>

#include "splitray/accel/bvh/wide_bvh.hpp"
#include "splitray/accel/bvh/wide_bvh_tests.hpp"

namespace splitray {

namespace {

using wide_bvh::prefetch;
using wide_bvh::test_leaf;
using wide_bvh::WatertightBlock;
using wide_bvh::WideSlab;

constexpr int kStackSize = kWideWidth * 64;  // fewer than kWideWidth pushes per level, 64 levels

struct Entry {
  std::uint32_t child;
  std::uint32_t count;  // 0: a wide node
  float t;
};

// What the plain traversal counts: nothing (every call compiles away).
struct NoCounts {
  void node(const WideNode&) {}
  void leaf(std::uint32_t) {}
};

// What the counting traversal adds up for the benchmark's profile (bench/bvh_bench.cpp).
struct Counting {
  WideBvhCounts& c;
  void node(const WideNode& n) {
    ++c.nodes;
    for (int i = 0; i < kWideWidth; ++i) c.boxes += n.planes[0][i] <= n.planes[3][i] ? 1 : 0;
  }
  void leaf(std::uint32_t blocks) {
    ++c.leaves;
    c.blocks += blocks;
  }
};

// One query's traversal, in one loop whose state (current entry, stack, closest hit) lives in
// locals the compiler keeps in registers. Children hit by the ray are entered nearest first;
// the others wait on the stack, farther ones lower, and are skipped once behind the closest
// hit. Returns true when an any-hit query found a hit.
template <bool AnyHit, class Counts = NoCounts>
bool traverse(std::span<const WideNode> node_span, std::span<const TriangleBlock> block_span,
              const Ray& ray, const Aabb& scene, float magnitude, Hit& hit, Counts counts = {}) {
  const WideNode* const nodes = node_span.data();
  const TriangleBlock* const blocks = block_span.data();
  const RobustRay r(ray, scene, magnitude);
  const WideSlab slab(r);
  // The triangle test's constants are made at the first leaf: many short rays (diffuse rays
  // leaving a surface) never reach one.
  std::optional<WatertightRay> w;
  std::optional<WatertightBlock> wb;
  const float tmin = ray.tmin;
  Hit best = hit;  // best.t: the far end of every test (tmax for an any-hit query)
  Entry stack[kStackSize];
  int sp = 0;
  Entry current{0, 0, 0};  // the root
  for (;;) {
    if (current.count == 0) {  // a wide node: enter the nearest hit child, push the others
      const WideNode& n = nodes[current.child];
      counts.node(n);
      alignas(64) float t_entry[kWideWidth];
      unsigned mask = slab.test(n, tmin, best.t, t_entry);
      // Ask for every child that will be visited or pushed at once: the memory loads overlap
      // instead of waiting for each other when the stack is popped.
      for (unsigned m = mask; m != 0; m &= m - 1) {
        const int c = std::countr_zero(m);
        if (n.count[c] == 0)
          prefetch<sizeof(WideNode)>(&nodes[n.child[c]]);
        else
          prefetch<sizeof(TriangleBlock)>(&blocks[n.child[c]]);
      }
      if (mask != 0) {
        int i = std::countr_zero(mask);
        mask &= mask - 1;
        Entry nearest{n.child[i], n.count[i], t_entry[i]};
        const int base = sp;
        while (mask != 0) {  // keep this node's entries ordered: farther ones lower
          i = std::countr_zero(mask);
          mask &= mask - 1;
          Entry e{n.child[i], n.count[i], t_entry[i]};
          if (e.t < nearest.t) std::swap(e, nearest);
          int j = sp++;
          for (; j > base && stack[j - 1].t < e.t; --j) stack[j] = stack[j - 1];
          stack[j] = e;
        }
        current = nearest;
        continue;
      }
    } else {  // a leaf: its blocks of eight triangles
      if (!wb) wb.emplace(w.emplace(ray));
      counts.leaf(current.count);
      if (test_leaf<AnyHit>(blocks + current.child, current.count, *w, *wb, tmin, best) && AnyHit)
        return true;
    }
    for (;;) {  // the next entry not behind the closest hit
      if (sp == 0) {
        hit = best;
        return false;
      }
      current = stack[--sp];
      if (current.t <= best.t) break;
    }
  }
}

}  // namespace

void WideBvh::intersect(const Ray& ray, const Aabb& scene, float magnitude, Hit& hit) const {
  if (nodes_.empty()) return;
  traverse<false>(nodes_, blocks_, ray, scene, magnitude, hit);
}

bool WideBvh::occluded(const Ray& ray, const Aabb& scene, float magnitude) const {
  if (nodes_.empty()) return false;
  Hit hit;
  hit.t = ray.tmax;
  return traverse<true>(nodes_, blocks_, ray, scene, magnitude, hit);
}

void WideBvh::intersect_counted(const Ray& ray, const Aabb& scene, float magnitude, Hit& hit,
                                WideBvhCounts& counts) const {
  ++counts.rays;
  if (nodes_.empty()) return;
  traverse<false>(nodes_, blocks_, ray, scene, magnitude, hit, Counting{counts});
}

}  // namespace splitray

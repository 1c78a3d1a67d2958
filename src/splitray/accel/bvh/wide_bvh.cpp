// Collapsing and traversing the eight-wide layout. The slab test is the same sequence of
// IEEE operations in the AVX and the scalar path (min/max operand order keeps NaN out, as in
// robust_ray.hpp), so both give the same answers.
#include "splitray/accel/bvh/wide_bvh.hpp"

#if defined(__SSE__)
#include <immintrin.h>
#endif

#include <bit>
#include <limits>

#include "splitray/accel/bvh/robust_ray.hpp"

namespace splitray {

namespace {

constexpr int kStackSize = 8 * 64;  // at most 7 pushes per level, at most 64 levels

struct Entry {
  std::uint32_t child;
  std::uint32_t count;  // 0: a wide node
  float t;
};

void set_slot(WideNode& w, int slot, const Aabb& box) {
  for (int a = 0; a < 3; ++a) {
    w.planes[a][slot] = box.lo[a];
    w.planes[3 + a][slot] = box.hi[a];
  }
}

std::uint32_t collapse_node(std::span<const BvhNode> nodes, std::uint32_t binary, std::vector<WideNode>& out,
                            std::vector<std::uint32_t>& source) {
  const auto index = static_cast<std::uint32_t>(out.size());
  out.emplace_back();
  source.resize(source.size() + kWideWidth, kInvalidId);
  std::uint32_t slots[kWideWidth];
  int count = 0;
  if (nodes[binary].leaf()) {
    slots[count++] = binary;
  } else {
    slots[count++] = nodes[binary].index;
    slots[count++] = nodes[binary].index + 1;
  }
  while (count < kWideWidth) {  // open the largest interior child
    int best = -1;
    float best_area = -1;
    for (int i = 0; i < count; ++i) {
      const BvhNode& n = nodes[slots[i]];
      if (!n.leaf() && n.box().half_area() > best_area) {
        best_area = n.box().half_area();
        best = i;
      }
    }
    if (best < 0) break;
    const std::uint32_t opened = slots[best];
    for (int i = count; i > best + 1; --i) slots[i] = slots[i - 1];
    slots[best] = nodes[opened].index;
    slots[best + 1] = nodes[opened].index + 1;
    ++count;
  }
  const Aabb empty;
  for (int i = 0; i < kWideWidth; ++i) {
    WideNode& w = out[index];
    w.child[i] = 0;
    w.count[i] = 0;
    set_slot(w, i, empty);
  }
  for (int i = 0; i < count; ++i) {
    const BvhNode& n = nodes[slots[i]];
    std::uint32_t child = n.index, refs = n.count();
    if (!n.leaf()) child = collapse_node(nodes, slots[i], out, source);  // may move `out`
    WideNode& w = out[index];
    set_slot(w, i, n.box());
    w.child[i] = child;
    w.count[i] = refs;
    source[index * kWideWidth + static_cast<std::uint32_t>(i)] = slots[i];
  }
  return index;
}

// The per-ray constants of the eight-wide slab test: plane rows by direction sign, and the
// origins and inverse direction broadcast once.
struct Slab8 {
  int near[3], far[3];
#if defined(__AVX__)
  __m256 org_near[3], org_far[3], inv[3];
#endif
  const RobustRay& r;

  explicit Slab8(const RobustRay& ray) : r(ray) {
    for (int a = 0; a < 3; ++a) {
      near[a] = r.negative[a] ? 3 + a : a;
      far[a] = r.negative[a] ? a : 3 + a;
#if defined(__AVX__)
      org_near[a] = _mm256_set1_ps(r.org_near[a]);
      org_far[a] = _mm256_set1_ps(r.org_far[a]);
      inv[a] = _mm256_set1_ps(r.inv[a]);
#endif
    }
  }

  // Entry parameters into all eight slots (within [tmin, tmax]); bit i set on a hit.
  unsigned test(const WideNode& n, float tmin, float tmax, float* t_entry) const {
#if defined(__AVX__)
    __m256 t0 = _mm256_set1_ps(tmin), t1 = _mm256_set1_ps(tmax);
    for (int a = 0; a < 3; ++a) {
      const __m256 lo = _mm256_sub_ps(_mm256_load_ps(n.planes[near[a]]), org_near[a]);
      const __m256 hi = _mm256_sub_ps(_mm256_load_ps(n.planes[far[a]]), org_far[a]);
      t0 = _mm256_max_ps(_mm256_mul_ps(lo, inv[a]), t0);  // NaN in the first operand keeps t0
      t1 = _mm256_min_ps(_mm256_mul_ps(hi, inv[a]), t1);
    }
    _mm256_store_ps(t_entry, t0);
    return static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(t0, t1, _CMP_LE_OQ)));
#else
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
#endif
  }
};

inline void prefetch(const WideNode* node) {
#if defined(__SSE__)
  const char* p = reinterpret_cast<const char*>(node);
  for (int line = 0; line < 4; ++line) _mm_prefetch(p + 64 * line, _MM_HINT_T0);
#else
  (void)node;
#endif
}

template <bool AnyHit>
bool traverse(std::span<const WideNode> nodes, const Ray& ray, const RobustRay& r, std::span<const Triangle> tris,
              std::span<const std::uint32_t> ids, Hit& hit) {
  const WatertightRay w(ray);
  const Slab8 slab(r);
  // Tests a leaf; true when an any-hit query is answered.
  const auto leaf = [&](std::uint32_t first, std::uint32_t count) {
    for (std::uint32_t i = first; i < first + count; ++i) {
      if constexpr (AnyHit) {
        float t, u, v;
        if (intersect_triangle(w, tris[i], ray.tmin, ray.tmax, t, u, v)) return true;
      } else {
        intersect_triangle(w, tris[i], ids[i], ray.tmin, hit);
      }
    }
    return false;
  };
  Entry stack[kStackSize];
  int sp = 0;
  Entry current{0, 0, 0};
  alignas(32) float t_entry[kWideWidth];
  for (;;) {
    if (current.count == 0) {  // a wide node: enter the nearest hit child, push the others
      const WideNode& n = nodes[current.child];
      unsigned mask = slab.test(n, ray.tmin, hit.t, t_entry);
      if (mask != 0) {
        int i = std::countr_zero(mask);
        mask &= mask - 1;
        Entry nearest{n.child[i], n.count[i], t_entry[i]};
        const int base = sp;
        while (mask != 0) {  // keep the stack ordered: farther entries lower
          i = std::countr_zero(mask);
          mask &= mask - 1;
          Entry e{n.child[i], n.count[i], t_entry[i]};
          if (e.t < nearest.t) std::swap(e, nearest);
          int j = sp++;
          for (; j > base && stack[j - 1].t < e.t; --j) stack[j] = stack[j - 1];
          stack[j] = e;
        }
        current = nearest;
        if (current.count == 0) prefetch(&nodes[current.child]);
        continue;
      }
    } else if (leaf(current.child, current.count)) {
      return true;
    }
    for (;;) {  // the next entry not behind the closest hit
      if (sp == 0) return hit.found();
      current = stack[--sp];
      if (current.t <= hit.t) break;
    }
  }
}

}  // namespace

void WideBvh::collapse(std::span<const BvhNode> nodes) {
  nodes_.clear();
  source_.clear();
  if (nodes.empty()) return;
  nodes_.reserve(nodes.size() / 4 + 1);
  collapse_node(nodes, 0, nodes_, source_);
}

void WideBvh::update_boxes(std::span<const BvhNode> nodes) {
  for (std::size_t w = 0; w < nodes_.size(); ++w)
    for (int i = 0; i < kWideWidth; ++i) {
      const std::uint32_t s = source_[w * kWideWidth + static_cast<std::size_t>(i)];
      if (s != kInvalidId) set_slot(nodes_[w], i, nodes[s].box());
    }
}

void WideBvh::intersect(const Ray& ray, const Aabb& scene, float magnitude, std::span<const Triangle> tris,
                        std::span<const std::uint32_t> ids, Hit& hit) const {
  if (nodes_.empty()) return;
  const RobustRay r(ray, scene, magnitude);
  traverse<false>(nodes_, ray, r, tris, ids, hit);
}

bool WideBvh::occluded(const Ray& ray, const Aabb& scene, float magnitude, std::span<const Triangle> tris) const {
  if (nodes_.empty()) return false;
  const RobustRay r(ray, scene, magnitude);
  Hit hit;
  hit.t = ray.tmax;
  return traverse<true>(nodes_, ray, r, tris, {}, hit);
}

}  // namespace splitray

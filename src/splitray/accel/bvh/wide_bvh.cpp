// Collapsing and traversing the eight-wide layout. The slab test is the same sequence of
// IEEE operations in the AVX and the scalar path (min/max operand order keeps NaN out, as in
// robust_ray.hpp), so both give the same answers.
#include "splitray/accel/bvh/wide_bvh.hpp"

#if defined(__AVX__)
#include <immintrin.h>
#endif

#include <bit>
#include <atomic>
#include <limits>

#include "splitray/accel/bvh/robust_ray.hpp"

namespace splitray {
std::atomic<long> g_nodes{0}, g_leaves{0}, g_tris{0};
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

// Entry parameters of the ray into all eight slots (within [tmin, tmax]); bit i set on a hit.
inline unsigned slab8(const WideNode& n, const RobustRay& r, const int near[3], const int far[3], float tmin,
                      float tmax, float* t_entry) {
#if defined(__AVX__)
  __m256 t0 = _mm256_set1_ps(tmin), t1 = _mm256_set1_ps(tmax);
  for (int a = 0; a < 3; ++a) {
    const __m256 inv = _mm256_set1_ps(r.inv[a]);
    const __m256 lo = _mm256_sub_ps(_mm256_load_ps(n.planes[near[a]]), _mm256_set1_ps(r.org_near[a]));
    const __m256 hi = _mm256_sub_ps(_mm256_load_ps(n.planes[far[a]]), _mm256_set1_ps(r.org_far[a]));
    t0 = _mm256_max_ps(_mm256_mul_ps(lo, inv), t0);  // NaN in the first operand keeps t0
    t1 = _mm256_min_ps(_mm256_mul_ps(hi, inv), t1);
  }
  _mm256_storeu_ps(t_entry, t0);
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

template <bool AnyHit>
bool traverse(std::span<const WideNode> nodes, const Ray& ray, const RobustRay& r, std::span<const Triangle> tris,
              std::span<const std::uint32_t> ids, Hit& hit) {
  const WatertightRay w(ray);
  int near[3], far[3];
  for (int a = 0; a < 3; ++a) {
    near[a] = r.negative[a] ? 3 + a : a;
    far[a] = r.negative[a] ? a : 3 + a;
  }
  // Tests a leaf; true when an any-hit query is answered.
  long c_nodes=0,c_leaves=0,c_tris=0;
  struct Flush{long&a;long&b;long&c; ~Flush(){g_nodes+=a;g_leaves+=b;g_tris+=c;}} flush{c_nodes,c_leaves,c_tris};
  const auto leaf = [&](std::uint32_t first, std::uint32_t count) {
    ++c_leaves; c_tris += count;
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
  std::uint32_t node = 0;
  alignas(32) float t_entry[kWideWidth];
  for (;;) {
    ++c_nodes;
    unsigned mask = slab8(nodes[node], r, near, far, ray.tmin, hit.t, t_entry);
    if (mask != 0) {
      const WideNode& n = nodes[node];
      // Push the hit children farthest first, so that the nearest is handled next.
      Entry found[kWideWidth];
      int k = 0;
      while (mask != 0) {
        const int i = std::countr_zero(mask);
        mask &= mask - 1;
        Entry e{n.child[i], n.count[i], t_entry[i]};
        int j = k++;
        for (; j > 0 && found[j - 1].t < e.t; --j) found[j] = found[j - 1];
        found[j] = e;
      }
      for (int j = 0; j < k - 1; ++j) stack[sp++] = found[j];
      const Entry& nearest = found[k - 1];
      if (nearest.count == 0) {
        node = nearest.child;
        continue;
      }
      if (leaf(nearest.child, nearest.count)) return true;
    }
    for (;;) {  // the next entry not behind the closest hit
      if (sp == 0) return hit.found();
      const Entry e = stack[--sp];
      if (!(e.t <= hit.t)) continue;
      if (e.count == 0) {
        node = e.child;
        break;
      }
      if (leaf(e.child, e.count)) return true;
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

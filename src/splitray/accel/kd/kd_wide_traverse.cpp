// Single-ray traversal of the wide layout (kd_wide.hpp): one step clips the ray's interval
// against the 7 planes of a node in SIMD and visits the occupied cells it reaches front to
// back. Each cell's interval is the binary traversal's (kd_traverse.cpp): the same
// t_split = (split - org) * inv, the same widening, and the same min/max compositions level by
// level (min and max are exact), so the two visit the same leaves with the same intervals and
// skip a far cell under the same rule; the answer is brute's.
//
// The walk is a resumable state machine (one node or leaf per step), so that the batched call
// can interleave the walks of several rays: their memory accesses, which dominate the time of
// incoherent rays, then overlap instead of waiting one after the other.
#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/accel/kd/kd_ray_setup.hpp"

#if defined(__AVX2__)
#include <immintrin.h>
#endif

namespace splitray {

#if defined(__AVX2__)

namespace {

struct CellEntry {
  std::uint32_t ref;
  float t0, t1;
};

constexpr int kStackSize = 7 * KdAccel::kWideDepthLimit + 1;

template <bool kAnyHit, bool kInterleaved>
class WideWalk {
 public:
  // `hit.t` must hold ray.tmax.
  WideWalk(const KdAccel::WideView& view, const Ray& ray, const KdRaySetup& setup, Hit& hit)
      : view_(view),
        wray_(ray),
        tmin_(ray.tmin),
        tmax_(ray.tmax),
        org8_(_mm256_setr_ps(setup.org[0], setup.org[1], setup.org[2], 0, 0, 0, 0, 0)),
        inv8_(_mm256_setr_ps(setup.inv[0], setup.inv[1], setup.inv[2], 1, 1, 1, 1, 1)),
        pad8_(_mm256_setr_ps(setup.pad[0], setup.pad[1], setup.pad[2], 0, 0, 0, 0, 0)),
        hit_(hit),
        ref_(view.root),
        t0_(setup.t0),
        t1_(setup.t1) {}

  bool result() const { return result_; }

  // Visits one node or leaf; true when the walk is over (then result() is the answer).
  // Interleaved walks (kInterleaved) prefetch what they visit next before yielding, and visit
  // a leaf in two steps (its range, then its triangles), so that the other walks' steps hide
  // the latency of each load.
  bool step() {
    if (ref_ == KdWideTree::kEmpty) return finish(false);
    if (!(ref_ & KdWideTree::kLeafRef)) {
      if (enter(view_.nodes[ref_])) return next();
    } else {
      if (kInterleaved && !leaf_ready_) {
        leaf_ = KdWideTree::leaf(ref_, view_.leaves);
        const char* rows = reinterpret_cast<const char*>(view_.rows->leaf(leaf_.first));
        const char* end = rows + 9 * sizeof(float) * std::size_t{leaf_.count};
        for (const char* line = rows; line < end && line < rows + std::ptrdiff_t{512};
             line += 64)  // 8 lines
          _mm_prefetch(line, _MM_HINT_T0);
        leaf_ready_ = true;
        return false;
      }
      if (!kInterleaved) leaf_ = KdWideTree::leaf(ref_, view_.leaves);
      leaf_ready_ = false;
      if (intersect_leaf<kAnyHit>(wray_, view_.rows->leaf(leaf_.first), view_.ids + leaf_.first,
                                  leaf_.count, tmin_, tmax_, hit_) &&
          kAnyHit)
        return finish(true);
    }
    while (top_ > 0) {
      const CellEntry& entry = stack_[--top_];
      if (kAnyHit || entry.t0 <= hit_.t) {
        ref_ = entry.ref;
        t0_ = entry.t0;
        t1_ = entry.t1;
        return next();
      }
    }
    return finish(!kAnyHit && hit_.found());
  }

 private:
  // ref_ is set: prefetch it for the next step (interleaved walks), the walk goes on.
  bool next() {
    if constexpr (kInterleaved) {
      if (ref_ & KdWideTree::kLeafRef) {
        if ((ref_ & KdWideTree::kIndirect) != KdWideTree::kIndirect)  // the rows themselves
          _mm_prefetch(reinterpret_cast<const char*>(view_.rows->leaf(
                           (ref_ & ~KdWideTree::kLeafRef) >> KdWideTree::kCountBits)),
                       _MM_HINT_T0);
        else
          _mm_prefetch(
              reinterpret_cast<const char*>(
                  view_.leaves + ((ref_ & ~KdWideTree::kLeafRef) >> KdWideTree::kCountBits)),
              _MM_HINT_T0);
      } else
        _mm_prefetch(reinterpret_cast<const char*>(view_.nodes + ref_), _MM_HINT_T0);
    }
    return false;
  }

  bool finish(bool result) {
    result_ = result;
    return true;
  }

  // Clips the ray to the node's cells; false when it reaches none.
  bool enter(const KdWideNode& node) {
    // Planes per cell at levels 1 and 2 (level 0: plane 0 everywhere), and the cells above
    // the plane of each level.
    const __m256i level0 = _mm256_setzero_si256();
    const __m256i level1 = _mm256_setr_epi32(1, 1, 1, 1, 2, 2, 2, 2);
    const __m256i level2 = _mm256_setr_epi32(3, 3, 4, 4, 5, 5, 6, 6);
    const __m256 above0 = _mm256_castsi256_ps(_mm256_setr_epi32(0, 0, 0, 0, -1, -1, -1, -1));
    const __m256 above1 = _mm256_castsi256_ps(_mm256_setr_epi32(0, 0, -1, -1, 0, 0, -1, -1));
    const __m256 above2 = _mm256_castsi256_ps(_mm256_setr_epi32(0, -1, 0, -1, 0, -1, 0, -1));
    const __m256i axis_shift = _mm256_setr_epi32(0, 2, 4, 6, 8, 10, 12, 0);

    const __m256 split = _mm256_load_ps(node.split);  // lane 7: meta, a normal float
    const __m256i axis = _mm256_and_si256(
        _mm256_srlv_epi32(_mm256_set1_epi32(static_cast<int>(node.meta)), axis_shift),
        _mm256_set1_epi32(3));
    const __m256 inv = _mm256_permutevar8x32_ps(inv8_, axis);
    const __m256 pad = _mm256_permutevar8x32_ps(pad8_, axis);
    const __m256 t_split =
        _mm256_mul_ps(_mm256_sub_ps(split, _mm256_permutevar8x32_ps(org8_, axis)), inv);
    const __m256 hi = _mm256_add_ps(t_split, pad), lo = _mm256_sub_ps(t_split, pad);
    const __m256 negative = _mm256_cmp_ps(inv, _mm256_setzero_ps(), _CMP_LT_OQ);
    __m256 lower = _mm256_set1_ps(t0_), upper = _mm256_set1_ps(t1_);
    // Level by level: the cell on the ray's first side of the plane gets min(hi, t1), the
    // other max(lo, t0), exactly as in the binary step (_mm256_min_ps(x, y) is x < y ? x : y).
    const auto clip = [&](__m256i planes, __m256 above) {
      const __m256 second = _mm256_xor_ps(above, _mm256_permutevar8x32_ps(negative, planes));
      const __m256 h = _mm256_permutevar8x32_ps(hi, planes);
      const __m256 l = _mm256_permutevar8x32_ps(lo, planes);
      upper = _mm256_blendv_ps(_mm256_min_ps(h, upper), upper, second);
      lower = _mm256_blendv_ps(lower, _mm256_max_ps(l, lower), second);
      return static_cast<unsigned>(_mm256_movemask_ps(second));
    };
    const unsigned s0 = clip(level0, above0), s1 = clip(level1, above1), s2 = clip(level2, above2);
    const unsigned enter =
        static_cast<unsigned>(_mm256_movemask_ps(_mm256_cmp_ps(lower, upper, _CMP_LE_OQ))) &
        node.occupied();
    if (!enter) return false;
    alignas(32) float lo_t[8], hi_t[8];
    _mm256_store_ps(lo_t, lower);
    _mm256_store_ps(hi_t, upper);
    if ((enter & (enter - 1)) == 0) {  // one cell (the common case): no order to find
      const unsigned c = static_cast<unsigned>(__builtin_ctz(enter));
      ref_ = node.child[c];
      t0_ = lo_t[c];
      t1_ = hi_t[c];
      return true;
    }
    // The binary traversal's order: first sides first, level by level.
    std::uint8_t cell_of[8];
    unsigned order = 0;
    for (unsigned m = enter; m; m &= m - 1) {
      const unsigned c = static_cast<unsigned>(__builtin_ctz(m));
      const unsigned key = ((s0 >> c) & 1u) << 2 | ((s1 >> c) & 1u) << 1 | ((s2 >> c) & 1u);
      cell_of[key] = static_cast<std::uint8_t>(c);
      order |= 1u << key;
    }
    const unsigned first = static_cast<unsigned>(__builtin_ctz(order));
    for (unsigned m = order & ~(1u << first); m;) {  // the others, farthest pushed first
      const unsigned key = 31u - static_cast<unsigned>(__builtin_clz(m));
      const unsigned c = cell_of[key];
      stack_[top_++] = {node.child[c], lo_t[c], hi_t[c]};
      m &= ~(1u << key);
    }
    const unsigned c = cell_of[first];
    ref_ = node.child[c];
    t0_ = lo_t[c];
    t1_ = hi_t[c];
    return true;
  }

  const KdAccel::WideView& view_;
  WatertightRay wray_;
  float tmin_, tmax_;
  __m256 org8_, inv8_, pad8_;
  Hit& hit_;
  std::uint32_t ref_;
  float t0_, t1_;
  int top_ = 0;
  bool result_ = false;
  bool leaf_ready_ = false;  // interleaved: leaf_ holds the range of the leaf ref_
  KdWideLeaf leaf_{};
  CellEntry stack_[kStackSize];
};

}  // namespace

KdAccel::WideView KdAccel::wide_view() const {
  return {wide_.nodes.data(), wide_.leaves.data(), tree_.prim_ids.data(), &leaf_triangles_,
          wide_.root};
}

template <bool kAnyHit>
bool KdAccel::traverse_wide(const Ray& ray, const KdRaySetup& setup, Hit& hit) const {
  const WideView view = wide_view();
  WideWalk<kAnyHit, false> walk(view, ray, setup, hit);
  while (!walk.step()) {
  }
  return walk.result();
}

template bool KdAccel::traverse_wide<false>(const Ray&, const KdRaySetup&, Hit&) const;
template bool KdAccel::traverse_wide<true>(const Ray&, const KdRaySetup&, Hit&) const;

template <bool kAnyHit>
void KdAccel::walk_interleaved(const Ray* rays, const std::uint32_t* which, std::size_t n,
                               Hit* hits, std::uint8_t* occluded) const {
  if (!interleave_) return walk_each<kAnyHit>(rays, which, n, hits, occluded);
  // Enough walks in flight to hide a load's latency: 16 against 8, diffuse rays +2% (geomean
  // of the 15 meshes, -t 1, 5 alternating rounds; 11 faster); 24 and 32 were slower.
  constexpr int kWalks = 16;
  using Walk = WideWalk<kAnyHit, true>;
  const WideView view = wide_view();
  alignas(Walk) unsigned char storage[kWalks][sizeof(Walk)];
  Walk* walks[kWalks] = {};
  Hit any_hit[kWalks];  // the walks' hit records for occlusion
  std::uint32_t slot_ray[kWalks] = {};
  std::size_t next = 0;
  // Starts the next ray that needs a walk in `slot`; rays the walk does not take are answered
  // at once by the single-ray call.
  const auto start = [&](int slot) {
    while (next < n) {
      const std::uint32_t i = which[next++];
      const Ray& ray = rays[i];
      Hit& hit = kAnyHit ? any_hit[slot] : hits[i];
      hit = Hit{};
      hit.t = ray.tmax;
      if (ray.tmin <= ray.tmax && KdRaySetup::traversable(ray) &&
          wide_.root != KdWideTree::kEmpty) {
        const KdRaySetup setup(ray, tree_.bounds, coord_scale_);
        if (setup.t0 <= setup.t1) {
          walks[slot] = new (storage[slot]) Walk(view, ray, setup, hit);
          slot_ray[slot] = i;
          return;
        }
      }
      if constexpr (kAnyHit)
        occluded[i] = KdAccel::any_hit(ray) ? 1 : 0;
      else
        hit = KdAccel::closest_hit(ray);
    }
    walks[slot] = nullptr;
  };
  int live = 0;
  for (int s = 0; s < kWalks; ++s) {
    start(s);
    live += walks[s] != nullptr;
  }
  while (live > 0) {
    for (int s = 0; s < kWalks; ++s) {
      if (!walks[s] || !walks[s]->step()) continue;
      if constexpr (kAnyHit)
        occluded[slot_ray[s]] = walks[s]->result() ? 1 : 0;
      else if (!walks[s]->result())
        hits[slot_ray[s]] = Hit{};
      walks[s]->~Walk();
      start(s);
      live -= walks[s] == nullptr;
    }
  }
}

template void KdAccel::walk_interleaved<false>(const Ray*, const std::uint32_t*, std::size_t, Hit*,
                                               std::uint8_t*) const;
template void KdAccel::walk_interleaved<true>(const Ray*, const std::uint32_t*, std::size_t, Hit*,
                                              std::uint8_t*) const;

#else

template <bool kAnyHit>
void KdAccel::walk_interleaved(const Ray* rays, const std::uint32_t* which, std::size_t n,
                               Hit* hits, std::uint8_t* occluded) const {
  walk_each<kAnyHit>(rays, which, n, hits, occluded);
}

template void KdAccel::walk_interleaved<false>(const Ray*, const std::uint32_t*, std::size_t, Hit*,
                                               std::uint8_t*) const;
template void KdAccel::walk_interleaved<true>(const Ray*, const std::uint32_t*, std::size_t, Hit*,
                                              std::uint8_t*) const;

#endif

template <bool kAnyHit>
void KdAccel::walk_each(const Ray* rays, const std::uint32_t* which, std::size_t n, Hit* hits,
                        std::uint8_t* occluded) const {
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t i = which[k];
    if constexpr (kAnyHit)
      occluded[i] = KdAccel::any_hit(rays[i]) ? 1 : 0;
    else
      hits[i] = KdAccel::closest_hit(rays[i]);
  }
}

}  // namespace splitray

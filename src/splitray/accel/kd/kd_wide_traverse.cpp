// The kd-tree's walk: front to back over the wide layout (kd_wide.hpp), exact against `brute`.
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
// core/triangle.hpp). So every plane is widened by the split style of robust_ray.hpp (a bound
// far above float rounding, far below any cell that matters for speed), and a far cell is
// skipped only when its widened entry t exceeds the best t (traversal_stack.hpp).
//
// One step clips the ray's interval against the 7 planes of a node (kd_wide_clip.hpp: the
// binary tree's clipping, operation for operation, level by level) and visits the occupied
// cells it reaches front to back. The walk is a resumable state machine (one node or leaf per
// step), so that the batched call can interleave the walks of several rays: their memory
// accesses, which dominate the time of incoherent rays, then overlap instead of waiting one
// after the other.
#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/accel/kd/kd_wide_clip.hpp"
#include "splitray/accel/robust_ray.hpp"
#include "splitray/accel/traversal_stack.hpp"

namespace splitray {

namespace {

struct CellEntry {
  std::uint32_t ref;
  float t0, t1;
};

constexpr int kStackSize = 7 * KdAccel::kWideDepthLimit + 1;

// Asks for the cache line at p (prefetcht0).
inline void prefetch(const void* p) { __builtin_prefetch(p, 0, 3); }

// The per-axis constants of a ray as the 7-plane clip takes them.
struct WideRay {
#if defined(__AVX2__)
  simd::Float8 org, inv, pad;
  WideRay(const RobustRay& r, const RobustRay::Splits& s)
      : org(_mm256_setr_ps(r.org.x, r.org.y, r.org.z, 0, 0, 0, 0, 0)),
        inv(_mm256_setr_ps(r.inv.x, r.inv.y, r.inv.z, 1, 1, 1, 1, 1)),
        pad(_mm256_setr_ps(s.pad[0], s.pad[1], s.pad[2], 0, 0, 0, 0, 0)) {}
#else
  float org[3], inv[3], pad[3];
  WideRay(const RobustRay& r, const RobustRay::Splits& s)
      : org{r.org.x, r.org.y, r.org.z},
        inv{r.inv.x, r.inv.y, r.inv.z},
        pad{s.pad[0], s.pad[1], s.pad[2]} {}
#endif
  KdCellClip clip(const KdWideNode& node, float t0, float t1) const {
    return clip_cells(node, org, inv, pad, t0, t1);
  }
};

template <bool kAnyHit, bool kInterleaved>
class WideWalk {
 public:
  // `hit.t` must hold ray.tmax; `s` is r.splits(root cell, ray.tmin, ray.tmax), not empty.
  WideWalk(const KdAccel::WideView& view, const Ray& ray, const RobustRay& r,
           const RobustRay::Splits& s, Hit& hit)
      : view_(view),
        wray_(ray),
        tmin_(ray.tmin),
        tmax_(ray.tmax),
        ray_(r, s),
        hit_(hit),
        ref_(view.root),
        t0_(s.t0),
        t1_(s.t1) {}

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
          prefetch(line);
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
    if (const CellEntry* entry = stack_.pop_not_behind(hit_.t)) {
      ref_ = entry->ref;
      t0_ = entry->t0;
      t1_ = entry->t1;
      return next();
    }
    return finish(!kAnyHit && hit_.found());
  }

 private:
  // ref_ is set: prefetch it for the next step (interleaved walks), the walk goes on.
  bool next() {
    if constexpr (kInterleaved) {
      if (ref_ & KdWideTree::kLeafRef) {
        if ((ref_ & KdWideTree::kIndirect) != KdWideTree::kIndirect)  // the rows themselves
          prefetch(view_.rows->leaf((ref_ & ~KdWideTree::kLeafRef) >> KdWideTree::kCountBits));
        else
          prefetch(view_.leaves + ((ref_ & ~KdWideTree::kLeafRef) >> KdWideTree::kCountBits));
      } else
        prefetch(view_.nodes + ref_);
    }
    return false;
  }

  bool finish(bool result) {
    result_ = result;
    return true;
  }

  // Clips the ray to the node's cells; false when it reaches none.
  bool enter(const KdWideNode& node) {
    const KdCellClip cells = ray_.clip(node, t0_, t1_);
    const unsigned enter = cells.enter;
    if (!enter) return false;
    if ((enter & (enter - 1)) == 0) {  // one cell (the common case): no order to find
      const unsigned c = static_cast<unsigned>(__builtin_ctz(enter));
      ref_ = node.child[c];
      t0_ = cells.t0[c];
      t1_ = cells.t1[c];
      return true;
    }
    // The binary traversal's order: first sides first, level by level.
    std::uint8_t cell_of[8];
    unsigned order = 0;
    for (unsigned m = enter; m; m &= m - 1) {
      const unsigned c = static_cast<unsigned>(__builtin_ctz(m));
      const unsigned key = ((cells.second[0] >> c) & 1u) << 2 | ((cells.second[1] >> c) & 1u) << 1 |
                           ((cells.second[2] >> c) & 1u);
      cell_of[key] = static_cast<std::uint8_t>(c);
      order |= 1u << key;
    }
    const unsigned first = static_cast<unsigned>(__builtin_ctz(order));
    for (unsigned m = order & ~(1u << first); m;) {  // the others, farthest pushed first
      const unsigned key = 31u - static_cast<unsigned>(__builtin_clz(m));
      const unsigned c = cell_of[key];
      stack_.push({node.child[c], cells.t0[c], cells.t1[c]});
      m &= ~(1u << key);
    }
    const unsigned c = cell_of[first];
    ref_ = node.child[c];
    t0_ = cells.t0[c];
    t1_ = cells.t1[c];
    return true;
  }

  const KdAccel::WideView& view_;
  WatertightRay wray_;
  float tmin_, tmax_;
  WideRay ray_;
  Hit& hit_;
  std::uint32_t ref_;
  float t0_, t1_;
  bool result_ = false;
  bool leaf_ready_ = false;  // interleaved: leaf_ holds the range of the leaf ref_
  KdWideLeaf leaf_{};
  TraversalStack<CellEntry, kStackSize> stack_;
};

}  // namespace

KdAccel::WideView KdAccel::wide_view() const {
  return {wide_.nodes.data(), wide_.leaves.data(), tree_.prim_ids.data(), &leaf_triangles_,
          wide_.root};
}

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
  if (!RobustRay::traversable(ray)) return scan<kAnyHit>(ray, hit);
  const RobustRay r(ray, tree_.bounds, coord_scale_);
  const RobustRay::Splits s = r.splits(tree_.bounds, ray.tmin, ray.tmax);
  if (!(s.t0 <= s.t1)) return false;
  const WideView view = wide_view();  // the walk keeps a reference
  WideWalk<kAnyHit, false> walk(view, ray, r, s, hit);
  while (!walk.step()) {
  }
  return walk.result();
}

template bool KdAccel::traverse<false>(const Ray&, Hit&) const;
template bool KdAccel::traverse<true>(const Ray&, Hit&) const;

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
      if (ray.tmin <= ray.tmax && RobustRay::traversable(ray) && wide_.root != KdWideTree::kEmpty) {
        const RobustRay r(ray, tree_.bounds, coord_scale_);
        const RobustRay::Splits s = r.splits(tree_.bounds, ray.tmin, ray.tmax);
        if (s.t0 <= s.t1) {
          walks[slot] = new (storage[slot]) Walk(view, ray, r, s, hit);
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

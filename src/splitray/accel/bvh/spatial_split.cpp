#include "splitray/accel/bvh/spatial_split.hpp"

#include <algorithm>
#include <array>
#include <utility>

#include "splitray/accel/bvh/object_split.hpp"
#include "splitray/core/parallel.hpp"

#if defined(__SSE2__)
#include <immintrin.h>
#endif

namespace splitray {

namespace {

constexpr int kMaxSpatialBins = 256;
constexpr std::size_t kParallelRefs = 16384, kChunkRefs = 8192;
constexpr float kInf = std::numeric_limits<float>::infinity();

// The slabs of each axis: plane i at lo + i * width, the one formula of binning and splitting.
struct Slabs {
  int count;
  float lo[3], width[3], inv[3];
  bool used[3];
  Slabs(const Aabb& box, int bins) : count(bins) {
    for (int a = 0; a < 3; ++a) {
      const float extent = box.hi[a] - box.lo[a];
      used[a] = extent > 0;
      lo[a] = box.lo[a];
      width[a] = extent / static_cast<float>(count);
      inv[a] = used[a] ? static_cast<float>(count) / extent : 0.0f;
    }
  }
  float plane(int axis, int i) const { return lo[axis] + static_cast<float>(i) * width[axis]; }
  int slab(int axis, float x) const {
    return std::clamp(static_cast<int>((x - lo[axis]) * inv[axis]), 0, count - 1);
  }
};

struct SpatialBins {
  struct Bin {  // raw: only the bins in use are initialised
    alignas(16) float lo[4];
    alignas(16) float hi[4];  // lane 3 unused
    std::uint32_t enter, exit;
    void clear() {
      std::fill(std::begin(lo), std::end(lo), kInf);
      std::fill(std::begin(hi), std::end(hi), -kInf);
      enter = exit = 0;
    }
    Aabb box() const { return {{lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}}; }
    void extend(const Aabb& b) {
      for (int k = 0; k < 3; ++k)
        lo[k] = std::min(lo[k], b.lo[k]), hi[k] = std::max(hi[k], b.hi[k]);
    }
  };
  int count;
  Bin bin[kMaxSpatialBins][3];  // [slab][axis]; only `count` in use

  explicit SpatialBins(int n) : count(n) {
    for (int i = 0; i < count; ++i)
      for (Bin& b : bin[i]) b.clear();
  }
  SpatialBins(const SpatialBins& o) : count(o.count) {
    std::copy_n(&o.bin[0][0], 3 * count, &bin[0][0]);
  }
  SpatialBins& operator=(const SpatialBins&) = delete;

  void merge(const SpatialBins& o) {
    for (int i = 0; i < count; ++i)
      for (int a = 0; a < 3; ++a) {
        bin[i][a].extend(o.bin[i][a].box());
        bin[i][a].enter += o.bin[i][a].enter;
        bin[i][a].exit += o.bin[i][a].exit;
      }
  }

  void add(const BvhRef& r, const Triangle& t, const Slabs& s) {
    for (int a = 0; a < 3; ++a) {
      if (!s.used[a]) continue;
      const int b0 = s.slab(a, r.box.lo[a]);
      const int b1 = std::max(s.slab(a, r.box.hi[a]), b0);
      ++bin[b0][a].enter;
      ++bin[b1][a].exit;
      if (b0 == b1)
        bin[b0][a].extend(r.box);
      else
        chop(r.box, t, a, b0, b1, s);
    }
  }

  // The bounds of the triangle's part in each slab b0..b1 (the outer two open outward), cut
  // to the reference's box, in one walk up the axis: a slab holds the vertices inside it and
  // the triangle's cuts by its two planes (a plane cuts the longest edge and one other).
#if defined(__SSE2__)
  void chop(const Aabb& ref, const Triangle& t, int a, int b0, int b1, const Slabs& s) {
    alignas(16) float v[3][4] = {
        {t.v0.x, t.v0.y, t.v0.z, 0}, {t.v1.x, t.v1.y, t.v1.z, 0}, {t.v2.x, t.v2.y, t.v2.z, 0}};
    int o[3] = {0, 1, 2};  // vertices in order along the axis
    if (v[o[1]][a] < v[o[0]][a]) std::swap(o[0], o[1]);
    if (v[o[2]][a] < v[o[1]][a]) std::swap(o[1], o[2]);
    if (v[o[1]][a] < v[o[0]][a]) std::swap(o[0], o[1]);
    const __m128 p[3] = {_mm_load_ps(v[o[0]]), _mm_load_ps(v[o[1]]), _mm_load_ps(v[o[2]])};
    const float at[3] = {v[o[0]][a], v[o[1]][a], v[o[2]][a]};
    const __m128 ref_lo = _mm_setr_ps(ref.lo.x, ref.lo.y, ref.lo.z, 0);
    const __m128 ref_hi = _mm_setr_ps(ref.hi.x, ref.hi.y, ref.hi.z, 0);
    alignas(16) float lane[4] = {0, 0, 0, 0};
    lane[a] = 1;
    const __m128 on_axis = _mm_cmpneq_ps(_mm_load_ps(lane), _mm_setzero_ps());
    const __m128 inf = _mm_set1_ps(kInf), minus_inf = _mm_set1_ps(-kInf);
    // Point of edge (i, j), at[i] < q < at[j], on plane q, kept on the edge despite rounding.
    const auto cross = [&](int i, int j, float q) {
      const __m128 f = _mm_set1_ps((q - at[i]) / (at[j] - at[i]));
      const __m128 x = _mm_add_ps(p[i], _mm_mul_ps(_mm_sub_ps(p[j], p[i]), f));
      return _mm_max_ps(_mm_min_ps(x, _mm_max_ps(p[i], p[j])), _mm_min_ps(p[i], p[j]));
    };
    __m128 part_lo = inf, part_hi = minus_inf;  // of the current slab, from below
    int next = 0;
    for (int b = b0; b <= b1; ++b) {
      const float upper = b < b1 ? s.plane(a, b + 1) : kInf;
      for (; next < 3 && at[next] < upper; ++next)
        part_lo = _mm_min_ps(part_lo, p[next]), part_hi = _mm_max_ps(part_hi, p[next]);
      __m128 cut_lo = inf, cut_hi = minus_inf;  // the triangle's section by the upper plane
      if (b < b1 && at[0] < upper && upper < at[2]) {
        const __m128 x = cross(0, 2, upper);
        const __m128 y = upper < at[1]   ? cross(0, 1, upper)
                         : upper > at[1] ? cross(1, 2, upper)
                                         : p[1];
        cut_lo = _mm_min_ps(x, y);
        cut_hi = _mm_max_ps(x, y);
        part_lo = _mm_min_ps(part_lo, cut_lo);
        part_hi = _mm_max_ps(part_hi, cut_hi);
      }
      const float lower = b > b0 ? s.plane(a, b) : -kInf;
      // The part cut to the reference and, on the axis, to the slab.
      const auto on = [&](float x, __m128 off) {
        return _mm_or_ps(_mm_and_ps(on_axis, _mm_set1_ps(x)), _mm_andnot_ps(on_axis, off));
      };
      const __m128 box_lo = _mm_max_ps(_mm_max_ps(part_lo, ref_lo), on(lower, minus_inf));
      const __m128 box_hi = _mm_min_ps(_mm_min_ps(part_hi, ref_hi), on(upper, inf));
      if ((_mm_movemask_ps(_mm_cmpgt_ps(box_lo, box_hi)) & 7) == 0) {
        Bin& target = bin[b][a];
        _mm_store_ps(target.lo, _mm_min_ps(_mm_load_ps(target.lo), box_lo));
        _mm_store_ps(target.hi, _mm_max_ps(_mm_load_ps(target.hi), box_hi));
      }
      part_lo = cut_lo;
      part_hi = cut_hi;
    }
  }
#else
  void chop(const Aabb& ref, const Triangle& t, int a, int b0, int b1, const Slabs& s) {
    Vec3 v[3] = {t.v0, t.v1, t.v2};
    if (v[1][a] < v[0][a]) std::swap(v[0], v[1]);
    if (v[2][a] < v[1][a]) std::swap(v[1], v[2]);
    if (v[1][a] < v[0][a]) std::swap(v[0], v[1]);
    const auto cross = [&](const Vec3& p, const Vec3& q, float x) {
      const Vec3 c = p + (q - p) * ((x - p[a]) / (q[a] - p[a]));
      return max(min(c, max(p, q)), min(p, q));
    };
    Aabb part;  // of the current slab, from below
    int next = 0;
    for (int b = b0; b <= b1; ++b) {
      const float upper = b < b1 ? s.plane(a, b + 1) : kInf;
      for (; next < 3 && v[next][a] < upper; ++next) part.extend(v[next]);
      Aabb cut;  // the triangle's section by the upper plane
      if (b < b1 && v[0][a] < upper && upper < v[2][a]) {
        cut.extend(cross(v[0], v[2], upper));
        cut.extend(upper < v[1][a]   ? cross(v[0], v[1], upper)
                   : upper > v[1][a] ? cross(v[1], v[2], upper)
                                     : v[1]);
        part.extend(cut);
      }
      Aabb box = intersection(part, ref);
      if (b > b0) box.lo[a] = std::max(box.lo[a], s.plane(a, b));
      box.hi[a] = std::min(box.hi[a], upper);
      if (!box.empty()) bin[b][a].extend(box);
      part = cut;
    }
  }
#endif

  SpatialSplit best(std::size_t n, const Aabb& box, const Slabs& s, const BvhBuildOptions& options,
                    std::uint64_t& evals) const {
    SpatialSplit best;
    int best_slab = 0;
    const SplitMeasure& measure = options.measure;
    const float parent_measure = std::max(measure(box), std::numeric_limits<float>::min());
    float right_measure[kMaxSpatialBins];
    for (int a = 0; a < 3; ++a) {
      if (!s.used[a]) continue;
      Aabb acc;
      for (int i = count - 1; i > 0; --i) {
        acc.extend(bin[i][a].box());
        right_measure[i] = measure(acc);
      }
      Aabb left;
      std::size_t n_left = 0, n_right = n;
      for (int i = 0; i < count - 1; ++i) {
        left.extend(bin[i][a].box());
        n_left += bin[i][a].enter;
        n_right -= bin[i][a].exit;
        if (n_left == 0 || n_right == 0) continue;
        ++evals;
        const float cost = bvh_split_cost(options, parent_measure, measure(left), n_left,
                                          right_measure[i + 1], n_right);
        if (cost < best.cost) {
          best = {a, s.plane(a, i + 1), cost, left, {}, n_left, n_right};
          best_slab = i + 1;
        }
      }
    }
    if (best.axis >= 0)
      for (int i = best_slab; i < count; ++i) best.right.extend(bin[i][best.axis].box());
    return best;
  }
};

}  // namespace

SpatialSplit find_spatial_split(std::span<const BvhRef> refs, std::span<const Triangle> triangles,
                                const Aabb& box, const BvhBuildOptions& options,
                                std::uint64_t& evals) {
  // 4 + n / 4 slabs up to spatial_bins: a reference is chopped at every plane it crosses, and
  // small nodes gain little from fine slabs.
  const int count = std::clamp(
      std::min(options.spatial_bins, static_cast<int>(4 + refs.size() / 4)), 2, kMaxSpatialBins);
  const Slabs slabs(box, count);
  const auto bin_all = [&](std::size_t begin, std::size_t end, SpatialBins& bins) {
    for (std::size_t i = begin; i < end; ++i) bins.add(refs[i], triangles[refs[i].prim], slabs);
  };
  if (refs.size() < kParallelRefs) {
    SpatialBins bins(count);
    bin_all(0, refs.size(), bins);
    return bins.best(refs.size(), box, slabs, options, evals);
  }
  const SpatialBins bins =
      parallel_reduce(refs.size(), kChunkRefs, SpatialBins(count), bin_all,
                      [](SpatialBins& total, const SpatialBins& part) { total.merge(part); });
  return bins.best(refs.size(), box, slabs, options, evals);
}

}  // namespace splitray

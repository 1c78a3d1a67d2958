#include "splitray/accel/bvh/object_split.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <limits>
#include <utility>
#include <vector>

#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

// Chunks of parallel binning and partitioning: a chunk's work is tens of microseconds, well
// above a task's overhead.
constexpr std::size_t kChunkRefs = 16384;

constexpr float kInf = std::numeric_limits<float>::infinity();

#if defined(__SSE2__)
// The measures (SplitMeasure) of three boxes at once (lane a: the box of axis a), with the
// operations of Aabb::half_area and SplitMeasure in the same order, so each lane equals them bit
// for bit.
inline __m128 measures(const __m128 lo[3], const __m128 hi[3], const SplitMeasure& m) {
  const __m128 e0 = _mm_sub_ps(hi[0], lo[0]), e1 = _mm_sub_ps(hi[1], lo[1]),
               e2 = _mm_sub_ps(hi[2], lo[2]), zero = _mm_setzero_ps();
  const __m128 t0 = _mm_unpacklo_ps(e0, e1), t1 = _mm_unpackhi_ps(e0, e1);
  const __m128 t2 = _mm_unpacklo_ps(e2, zero), t3 = _mm_unpackhi_ps(e2, zero);
  const __m128 x = _mm_movelh_ps(t0, t2), y = _mm_movehl_ps(t2, t0), z = _mm_movelh_ps(t1, t3);
  const __m128 area = _mm_add_ps(_mm_add_ps(_mm_mul_ps(x, y), _mm_mul_ps(y, z)), _mm_mul_ps(z, x));
  if (m.volume_weight == 0) return area;
  const __m128 volume = _mm_mul_ps(_mm_mul_ps(x, y), z);
  return _mm_add_ps(area, _mm_mul_ps(_mm_set1_ps(m.volume_weight), volume));
}
#endif

}  // namespace

RefBounds ref_bounds(std::span<const BvhRef> refs) {
  const auto chunk = [&](std::size_t begin, std::size_t end) {
    RefBoundsAccumulator b;
    for (std::size_t i = begin; i < end; ++i) b.add(refs[i]);
    return b.bounds();
  };
  if (refs.size() < kParallelSplitRefs) return chunk(0, refs.size());
  return parallel_reduce(
      refs.size(), kChunkRefs, RefBounds{},
      [&](std::size_t begin, std::size_t end, RefBounds& acc) { acc.extend(chunk(begin, end)); },
      [](RefBounds& total, const RefBounds& part) { total.extend(part); });
}

CenterBins::CenterBins(const Aabb& centers, int bins)
    : lo(centers.lo), count(std::clamp(bins, 2, kMaxObjectBins)) {
  const Vec3 e = centers.extent();
  for (int a = 0; a < 3;
       ++a)  // slightly below count / extent: the top centre stays in the last bin
    scale[a] = e[a] > 0 ? static_cast<float>(count) * (1 - 0x1p-20f) / e[a] : 0.0f;
}

ObjectBins::ObjectBins(int count) : count_(count) {
  for (int i = 0; i < count_; ++i) {
    for (Box& b : box_[i]) {
      std::fill(std::begin(b.lo), std::end(b.lo), kInf);
      std::fill(std::begin(b.hi), std::end(b.hi), -kInf);
    }
    std::fill(std::begin(counts_[i]), std::end(counts_[i]), 0u);
  }
}

#if defined(__SSE2__)

// From this many references a node is binned in four sets of bins (add below); the merges cost
// little against the additions from here.
constexpr std::size_t kBinSetsFrom = 256;

void ObjectBins::add(std::span<const BvhRef> refs, const CenterBins& map) {
  // The bins of all three axes from one row: CenterBins::bin's operations lane by lane, the
  // clamp applied before the conversion (equal for the truncated value, and no overflow).
  const __m128 map_lo = _mm_setr_ps(map.lo.x, map.lo.y, map.lo.z, 0);
  const __m128 map_scale = _mm_setr_ps(map.scale.x, map.scale.y, map.scale.z, 0);
  const __m128 last = _mm_set1_ps(static_cast<float>(count_ - 1)), half = _mm_set1_ps(0.5f);
  const __m128 xyz = _mm_castsi128_ps(_mm_setr_epi32(-1, -1, -1, 0));
  const auto add_one = [&](ObjectBins& bins, const BvhRef& r) {
    const __m128 lo = _mm_loadu_ps(&r.box.lo.x);                   // lane 3: hi.x
    const __m128 hi = _mm_and_ps(_mm_loadu_ps(&r.box.hi.x), xyz);  // lane 3 (the id): 0
    const __m128 c = _mm_mul_ps(_mm_add_ps(lo, hi), half);
    __m128 f = _mm_mul_ps(_mm_sub_ps(c, map_lo), map_scale);
    f = _mm_min_ps(_mm_max_ps(f, _mm_setzero_ps()), last);
    alignas(16) std::int32_t b[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(b), _mm_cvttps_epi32(f));
    for (int a = 0; a < 3; ++a) {
      Box& box = bins.box_[b[a]][a];
      _mm_store_ps(box.lo, _mm_min_ps(_mm_load_ps(box.lo), lo));
      _mm_store_ps(box.hi, _mm_max_ps(_mm_load_ps(box.hi), hi));
      ++bins.counts_[b[a]][a];
    }
  };
  if (refs.size() < kBinSetsFrom) {
    for (const BvhRef& r : refs) add_one(*this, r);
    return;
  }
  // Consecutive references (neighbours in space, once the levels above have partitioned them)
  // often fall into the same bins, and each then waits for the previous one's stores to them:
  // four sets of bins taken in turn and merged (min, max and counts are exact, so the bins and
  // the tree are the same). Conference room binned build 0.80x of one set's time.
  ObjectBins second(count_), third(count_), fourth(count_);
  std::size_t i = 0;
  for (; i + 4 <= refs.size(); i += 4) {
    add_one(*this, refs[i]);
    add_one(second, refs[i + 1]);
    add_one(third, refs[i + 2]);
    add_one(fourth, refs[i + 3]);
  }
  for (; i < refs.size(); ++i) add_one(*this, refs[i]);
  merge(second);
  merge(third);
  merge(fourth);
}

void ObjectBins::merge(const ObjectBins& o) {
  for (int i = 0; i < count_; ++i) {
    for (int a = 0; a < 3; ++a) {
      Box& box = box_[i][a];
      _mm_store_ps(box.lo, _mm_min_ps(_mm_load_ps(box.lo), _mm_load_ps(o.box_[i][a].lo)));
      _mm_store_ps(box.hi, _mm_max_ps(_mm_load_ps(box.hi), _mm_load_ps(o.box_[i][a].hi)));
    }
    auto* c = reinterpret_cast<__m128i*>(counts_[i]);
    _mm_store_si128(c,
                    _mm_add_epi32(_mm_load_si128(c),
                                  _mm_load_si128(reinterpret_cast<const __m128i*>(o.counts_[i]))));
  }
}

ObjectSplit ObjectBins::best(const CenterBins& map, std::size_t n, const Aabb& box,
                             const BvhBuildOptions& options, std::uint64_t& evals) const {
  (void)n;
  const auto bin_counts = [&](int i) {
    return _mm_load_si128(reinterpret_cast<const __m128i*>(counts_[i]));
  };
  const auto extend = [&](__m128 lo[3], __m128 hi[3], int i) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = _mm_min_ps(lo[a], _mm_load_ps(box_[i][a].lo));
      hi[a] = _mm_max_ps(hi[a], _mm_load_ps(box_[i][a].hi));
    }
  };
  // Right to left: the measure and count right of each boundary, the axes in three lanes.
  const SplitMeasure& measure = options.measure;
  __m128 right_measure[kMaxObjectBins];
  __m128i right_count[kMaxObjectBins];
  __m128 lo[3], hi[3];
  for (int a = 0; a < 3; ++a) lo[a] = _mm_set1_ps(kInf), hi[a] = _mm_set1_ps(-kInf);
  __m128i count = _mm_setzero_si128();
  for (int i = count_ - 1; i > 0; --i) {
    count = _mm_add_epi32(count, bin_counts(i));
    extend(lo, hi, i);
    right_measure[i] = measures(lo, hi, measure);
    right_count[i] = count;
  }
  // Left to right: bvh_split_cost's operations lane by lane; the first least cost per axis.
  const float parent_measure = std::max(measure(box), std::numeric_limits<float>::min());
  const __m128 kt = _mm_set1_ps(options.traversal_cost),
               ki = _mm_set1_ps(options.intersection_cost);
  const __m128 pa = _mm_set1_ps(parent_measure), inf = _mm_set1_ps(kInf);
  const int shift = leaf_block_shift(options);
  const __m128i round = _mm_set1_epi32((1 << shift) - 1), zero = _mm_setzero_si128();
  const __m128i shift_count = _mm_cvtsi32_si128(shift);
  __m128 best_cost = inf;
  __m128i best_bin = zero;
  for (int a = 0; a < 3; ++a) lo[a] = _mm_set1_ps(kInf), hi[a] = _mm_set1_ps(-kInf);
  count = zero;
  unsigned valid_evals = 0;
  for (int i = 0; i < count_ - 1; ++i) {
    count = _mm_add_epi32(count, bin_counts(i));
    extend(lo, hi, i);
    const __m128 left_measure = measures(lo, hi, measure);
    const __m128i right = right_count[i + 1];
    const __m128 tests_left =
        _mm_cvtepi32_ps(_mm_srl_epi32(_mm_add_epi32(count, round), shift_count));
    const __m128 tests_right =
        _mm_cvtepi32_ps(_mm_srl_epi32(_mm_add_epi32(right, round), shift_count));
    const __m128 sum = _mm_add_ps(_mm_mul_ps(left_measure, tests_left),
                                  _mm_mul_ps(right_measure[i + 1], tests_right));
    __m128 cost = _mm_add_ps(kt, _mm_div_ps(_mm_mul_ps(ki, sum), pa));
    const __m128i empty = _mm_or_si128(_mm_cmpeq_epi32(count, zero), _mm_cmpeq_epi32(right, zero));
    const __m128 valid = _mm_castsi128_ps(_mm_andnot_si128(empty, _mm_set1_epi32(-1)));
    valid_evals +=
        static_cast<unsigned>(std::popcount(static_cast<unsigned>(_mm_movemask_ps(valid) & 7)));
    cost = _mm_or_ps(_mm_and_ps(valid, cost), _mm_andnot_ps(valid, inf));
    const __m128 better = _mm_cmplt_ps(cost, best_cost);
    best_cost = _mm_or_ps(_mm_and_ps(better, cost), _mm_andnot_ps(better, best_cost));
    const __m128i take = _mm_castps_si128(better);
    best_bin =
        _mm_or_si128(_mm_and_si128(take, _mm_set1_epi32(i)), _mm_andnot_si128(take, best_bin));
  }
  evals += valid_evals;

  alignas(16) float costs[4];
  alignas(16) std::int32_t bins[4];
  _mm_store_ps(costs, best_cost);
  _mm_store_si128(reinterpret_cast<__m128i*>(bins), best_bin);
  ObjectSplit best;
  best.cost = kInf;
  for (int a = 0; a < 3; ++a) {
    if (map.scale[a] == 0 || !(costs[a] < best.cost)) continue;
    best.cost = costs[a];
    best.axis = a;
    best.bin = bins[a];
  }
  if (best.axis < 0) return best;
  const int a = best.axis;
  for (int i = 0; i < count_; ++i) {
    const Aabb b{{box_[i][a].lo[0], box_[i][a].lo[1], box_[i][a].lo[2]},
                 {box_[i][a].hi[0], box_[i][a].hi[1], box_[i][a].hi[2]}};
    if (i <= best.bin) {
      best.left.extend(b);
      best.n_left += counts_[i][a];
    } else {
      best.right.extend(b);
    }
  }
  return best;
}

#else

void ObjectBins::add(std::span<const BvhRef> refs, const CenterBins& map) {
  for (const BvhRef& r : refs)
    for (int a = 0; a < 3; ++a) {
      Box& box = box_[map.bin(r, a)][a];
      for (int k = 0; k < 3; ++k)
        box.lo[k] = std::min(box.lo[k], r.box.lo[k]), box.hi[k] = std::max(box.hi[k], r.box.hi[k]);
      ++counts_[map.bin(r, a)][a];
    }
}

void ObjectBins::merge(const ObjectBins& o) {
  for (int i = 0; i < count_; ++i)
    for (int a = 0; a < 3; ++a) {
      for (int k = 0; k < 3; ++k) {
        box_[i][a].lo[k] = std::min(box_[i][a].lo[k], o.box_[i][a].lo[k]);
        box_[i][a].hi[k] = std::max(box_[i][a].hi[k], o.box_[i][a].hi[k]);
      }
      counts_[i][a] += o.counts_[i][a];
    }
}

ObjectSplit ObjectBins::best(const CenterBins& map, std::size_t n, const Aabb& box,
                             const BvhBuildOptions& options, std::uint64_t& evals) const {
  const auto bin_box = [&](int i, int a) {
    return Aabb{{box_[i][a].lo[0], box_[i][a].lo[1], box_[i][a].lo[2]},
                {box_[i][a].hi[0], box_[i][a].hi[1], box_[i][a].hi[2]}};
  };
  ObjectSplit best;
  best.cost = kInf;
  const SplitMeasure& measure = options.measure;
  const float parent_measure = std::max(measure(box), std::numeric_limits<float>::min());
  std::array<Aabb, kMaxObjectBins> right_box;
  for (int a = 0; a < 3; ++a) {
    if (map.scale[a] == 0) continue;
    Aabb acc;
    for (int i = count_ - 1; i > 0; --i) right_box[i] = acc = merge(acc, bin_box(i, a));
    Aabb left;
    std::size_t n_left = 0;
    for (int i = 0; i < count_ - 1; ++i) {
      left.extend(bin_box(i, a));
      n_left += counts_[i][a];
      const std::size_t n_right = n - n_left;
      if (n_left == 0 || n_right == 0) continue;
      ++evals;
      const float cost = bvh_split_cost(options, parent_measure, measure(left), n_left,
                                        measure(right_box[i + 1]), n_right);
      if (cost < best.cost) best = {a, i, cost, left, right_box[i + 1], n_left};
    }
  }
  return best;
}

#endif

ObjectSplit find_object_split(std::span<const BvhRef> refs, const RefBounds& bounds,
                              const BvhBuildOptions& options, std::uint64_t& evals) {
  const CenterBins map(bounds.centers, bin_count(options, refs.size()));
  if (refs.size() < kParallelSplitRefs) {
    ObjectBins bins(map.count);
    bins.add(refs, map);
    return bins.best(map, refs.size(), bounds.box, options, evals);
  }
  const ObjectBins bins = parallel_reduce(
      refs.size(), kChunkRefs, ObjectBins(map.count),
      [&](std::size_t begin, std::size_t end, ObjectBins& part) {
        part.add(refs.subspan(begin, end - begin), map);
      },
      [](ObjectBins& total, const ObjectBins& part) { total.merge(part); });
  return bins.best(map, refs.size(), bounds.box, options, evals);
}

namespace {

// Hoare partition of refs by goes_left, accumulating the bounds of both sides.
template <class GoesLeft>
std::size_t partition_span(std::span<BvhRef> refs, const GoesLeft& goes_left,
                           RefBoundsAccumulator& l, RefBoundsAccumulator& r) {
  std::size_t i = 0, j = refs.size();
  for (;;) {
    while (i < j && goes_left(refs[i])) l.add(refs[i++]);
    while (i < j && !goes_left(refs[j - 1])) r.add(refs[--j]);
    if (i >= j) break;
    std::swap(refs[i], refs[j - 1]);
    l.add(refs[i++]);
    r.add(refs[--j]);
  }
  return i;
}

// Positions [begin, end) of several ranges, walked as one sequence.
struct Ranges {
  std::vector<std::pair<std::size_t, std::size_t>> list;
  void add(std::size_t begin, std::size_t end) {
    if (begin < end) list.emplace_back(begin, end);
  }
  // Calls f(position) for the items [first, last) of the sequence.
  template <class F>
  void walk(std::size_t first, std::size_t last, const F& f) const {
    std::size_t skipped = 0;
    for (const auto& [begin, end] : list) {
      const std::size_t size = end - begin;
      if (skipped + size > first && skipped < last) {
        const std::size_t from = std::max(first, skipped) - skipped;
        const std::size_t to = std::min(last, skipped + size) - skipped;
        for (std::size_t k = from; k < to; ++k) f(begin + k);
      }
      skipped += size;
      if (skipped >= last) break;
    }
  }
};

}  // namespace

std::size_t partition_refs(std::span<BvhRef> refs, const CenterBins& bins, const ObjectSplit& split,
                           RefBounds& left, RefBounds& right) {
  const auto goes_left = [&](const BvhRef& r) { return bins.bin(r, split.axis) <= split.bin; };
  RefBoundsAccumulator l, r;
  const std::size_t n_left = partition_span(refs, goes_left, l, r);
  left.extend(l.bounds());
  right.extend(r.bounds());
  return n_left;
}

std::size_t partition_refs_parallel(std::span<BvhRef> refs, const CenterBins& bins,
                                    const ObjectSplit& split, RefBounds& left, RefBounds& right) {
  const auto goes_left = [&](const BvhRef& r) { return bins.bin(r, split.axis) <= split.bin; };
  const std::size_t n = refs.size();
  const std::size_t chunks = std::clamp<std::size_t>(n / kChunkRefs, 1, 64);
  const auto chunk_begin = [&](std::size_t c) { return n * c / chunks; };
  struct Part {
    std::size_t n_left = 0;
    RefBoundsAccumulator left, right;
  };
  // Each chunk partitioned in place: [its lefts | its rights].
  std::vector<Part> parts(chunks);
  parallel_for_each_index(chunks, [&](std::size_t c) {
    Part& p = parts[c];
    p.n_left = partition_span(refs.subspan(chunk_begin(c), chunk_begin(c + 1) - chunk_begin(c)),
                              goes_left, p.left, p.right);
  });
  std::size_t n_left = 0;
  for (const Part& p : parts) n_left += p.n_left;
  // The rights before n_left and the lefts after it are as many; the k-th of the one swaps
  // with the k-th of the other (positions in order, so the result depends only on the data).
  Ranges rights_before, lefts_after;
  for (std::size_t c = 0; c < chunks; ++c) {
    const std::size_t mid = chunk_begin(c) + parts[c].n_left;
    rights_before.add(mid, std::min(chunk_begin(c + 1), n_left));
    lefts_after.add(std::max(chunk_begin(c), n_left), mid);
  }
  std::size_t misplaced = 0;
  for (const auto& [begin, end] : rights_before.list) misplaced += end - begin;
  const std::size_t pieces = std::clamp<std::size_t>(misplaced / kChunkRefs, 1, 64);
  parallel_for_each_index(pieces, [&](std::size_t p) {
    const std::size_t first = misplaced * p / pieces, last = misplaced * (p + 1) / pieces;
    std::vector<std::size_t> from;
    from.reserve(last - first);
    rights_before.walk(first, last, [&](std::size_t i) { from.push_back(i); });
    std::size_t k = 0;
    lefts_after.walk(first, last, [&](std::size_t i) { std::swap(refs[from[k++]], refs[i]); });
  });
  for (std::size_t c = 1; c < chunks; ++c) {
    parts[0].left.add(parts[c].left);
    parts[0].right.add(parts[c].right);
  }
  left.extend(parts[0].left.bounds());
  right.extend(parts[0].right.bounds());
  return n_left;
}

}  // namespace splitray

#include "splitray/query/point_build.hpp"

#if defined(__AVX512F__)
#include <immintrin.h>
#endif
#if defined(__linux__)
#include <sys/mman.h>
#endif

#include <algorithm>
#include <array>
#include <bit>
#include <cstdlib>
#include <limits>
#include <memory>
#include <new>
#include <utility>

#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {
namespace {

enum class Heuristic { vvh, sah, median };

Heuristic parse_heuristic(const std::string& name) {
  if (name == "vvh") return Heuristic::vvh;
  if (name == "sah") return Heuristic::sah;
  if (name == "median") return Heuristic::median;
  throw Error("point tree builder", "unknown builder '" + name + "' (expected vvh, sah or median)");
}

// Float bits mapped to unsigned integers of the same order (-0 was canonicalised to +0).
std::uint32_t ordered_bits(float f) {
  const std::uint32_t u = std::bit_cast<std::uint32_t>(f);
  return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}

// Build scratch of n values, uninitialised (every slot is written before it is read). Large
// blocks ask Linux for transparent huge pages: the builder touches ~100 bytes per point once,
// and faulting that in 4 KiB pages costs a tenth of the build.
struct FreeScratch {
  void operator()(void* p) const { std::free(p); }
};
template <typename T>
using Scratch = std::unique_ptr<T[], FreeScratch>;

template <typename T>
Scratch<T> scratch(std::size_t n) {
  constexpr std::size_t kHuge = std::size_t{2} << 20;
  const std::size_t bytes = std::max<std::size_t>(n * sizeof(T), 1);
  const bool huge = bytes >= 4 * kHuge;
  const std::size_t align = huge ? kHuge : alignof(std::max_align_t) * 4;
  void* p = std::aligned_alloc(align, (bytes + align - 1) / align * align);
  if (!p) throw std::bad_alloc();
#if defined(__linux__)
  if (huge) madvise(p, bytes, MADV_HUGEPAGE);
#endif
  return Scratch<T>(static_cast<T*>(p));
}

// The points of one node ordered by one axis, as separate arrays: the sweep then reads one
// contiguous float array (vectorised), and partitioning needs no lookups into the caller's
// points. Build-time scratch only; the tree keeps none of it.
struct Columns {
  float* c[3];
  std::uint32_t* id;
};

struct Split {
  int axis = -1;
  std::size_t pos = 0;  // items [0, pos) of the node go below
  double cost = std::numeric_limits<double>::infinity();
};

int ceil_log2(std::size_t n) { return n <= 1 ? 0 : std::bit_width(n - 1); }

class Builder {
 public:
  Builder(std::span<const Vec3> points, const PointTreeConfig& config, float radius)
      : n_(points.size()),
        heuristic_(parse_heuristic(config.builder)),
        leaf_size_(static_cast<std::size_t>(config.leaf_size)),
        expansion_(2 * radius),
        traversal_cost_(config.traversal_cost),
        point_cost_(config.point_cost),
        coords_(scratch<float>(3 * 2 * 3 * points.size())),
        ids_(scratch<std::uint32_t>(3 * 2 * points.size())) {
    // For each axis, buffer 0 starts sorted by that axis; buffer 1 receives partitions.
    parallel_invoke([&] { fill(points, 0); }, [&] { fill(points, 1); }, [&] { fill(points, 2); });
  }

  void build(std::vector<PointNode>& out, std::size_t b, std::size_t e, const Aabb& cell, int depth,
             unsigned parity) {
    const std::size_t n = e - b;
    const Split split = n <= leaf_size_ || depth >= kPointTreeMaxDepth - 1
                            ? Split{}
                            : choose(b, e, cell, depth, parity);
    if (split.axis < 0) {
      PointNode leaf;
      leaf.index = static_cast<std::uint32_t>(b);
      leaf.bits = (static_cast<std::uint32_t>(n) << 2) | 3u;
      out.push_back(leaf);
      const Columns x = columns(0, parity);
      std::copy(x.id + b, x.id + e, permutation_.begin() + static_cast<std::ptrdiff_t>(b));
      return;
    }
    const int a = split.axis;
    const std::size_t m = b + split.pos;
    const float* keys = columns(a, parity).c[a];
    PointNode node;
    node.below_max = keys[m - 1];
    node.above_min = keys[m];
    node.bits = static_cast<std::uint32_t>(a);
    const unsigned child_parity = partition(b, e, a, node.above_min, split.pos, parity);
    Aabb below = cell, above = cell;
    below.hi[a] = node.below_max;
    above.lo[a] = node.above_min;

    const std::size_t self = out.size();
    out.push_back(node);
    if (n >= kParallelPoints) {
      std::vector<PointNode> below_nodes, above_nodes;
      parallel_invoke([&] { build(below_nodes, b, m, below, depth + 1, child_parity); },
                      [&] { build(above_nodes, m, e, above, depth + 1, child_parity); });
      out[self].index = static_cast<std::uint32_t>(1 + below_nodes.size());
      out.insert(out.end(), below_nodes.begin(), below_nodes.end());
      out.insert(out.end(), above_nodes.begin(), above_nodes.end());
    } else {
      build(out, b, m, below, depth + 1, child_parity);
      out[self].index = static_cast<std::uint32_t>(out.size() - self);
      build(out, m, e, above, depth + 1, child_parity);
    }
  }

  std::vector<std::uint32_t> take_permutation() { return std::move(permutation_); }
  void prepare_permutation() { permutation_.resize(n_); }

 private:
  static constexpr std::size_t kParallelPoints = 16384;  // smaller subtrees: one task
  static constexpr std::size_t kParallelAxes = 131072;   // larger nodes: axes in parallel
  static constexpr std::size_t kMaxCostLeaf = 1024;      // larger nodes split whatever the cost

  // Axis `sorted` (the order), buffer (parity bit): coordinates and ids.
  Columns columns(int sorted, unsigned parity) {
    const std::size_t buffer = static_cast<std::size_t>(sorted) * 2 + ((parity >> sorted) & 1u);
    Columns c;
    for (int m = 0; m < 3; ++m) c.c[m] = coords_.get() + (buffer * 3 + m) * n_;
    c.id = ids_.get() + buffer * n_;
    return c;
  }

  // Buffer 0 of `axis`: the points sorted by that coordinate with a stable LSD radix sort
  // (11 + 11 + 10 bits; equal coordinates keep index order), then their coordinates.
  void fill(std::span<const Vec3> points, int axis) {
    const std::size_t n = points.size();
    // (key << 32 | index): one array to scatter keeps the number of write streams low.
    Scratch<std::uint64_t> items = scratch<std::uint64_t>(n), tmp = scratch<std::uint64_t>(n);
    std::array<std::array<std::uint32_t, 2048>, 3> hist{};
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint32_t key = ordered_bits(points[i][axis] + 0.0f);  // -0 becomes +0
      items[i] = (static_cast<std::uint64_t>(key) << 32) | i;
      ++hist[0][key & 2047u];
      ++hist[1][(key >> 11) & 2047u];
      ++hist[2][key >> 22];
    }
    for (int pass = 0; pass < 3; ++pass) {
      auto& h = hist[pass];
      if (std::ranges::any_of(h, [&](std::uint32_t c) { return c == n; })) continue;  // one digit
      std::uint32_t sum = 0;
      for (auto& c : h) sum += std::exchange(c, sum);
      const int shift = 32 + 11 * pass;
      for (std::size_t i = 0; i < n; ++i) tmp[h[(items[i] >> shift) & 2047u]++] = items[i];
      items.swap(tmp);
    }
    const Columns c = columns(axis, 0);
    for (std::size_t i = 0; i < n; ++i) {
      const auto id = static_cast<std::uint32_t>(items[i]);
      const Vec3& p = points[id];
      for (int m = 0; m < 3; ++m) c.c[m][i] = p[m] + 0.0f;
      c.id[i] = id;
    }
  }

  Split choose(std::size_t b, std::size_t e, const Aabb& cell, int depth, unsigned parity) {
    // Near the depth limit, balanced splits keep every leaf within the query stack.
    if (heuristic_ == Heuristic::median || depth + ceil_log2(e - b) + 8 >= kPointTreeMaxDepth)
      return choose_median(b, e, parity);
    std::array<Split, 3> best;
    const auto sweep_axis = [&](int a) { best[a] = sweep(b, e, cell, a, parity); };
    if (e - b >= kParallelAxes)
      parallel_invoke([&] { sweep_axis(0); }, [&] { sweep_axis(1); }, [&] { sweep_axis(2); });
    else
      for (int a = 0; a < 3; ++a) sweep_axis(a);
    Split split;
    for (int a = 0; a < 3; ++a)
      if (best[a].axis >= 0 && best[a].cost < split.cost) split = best[a];
    if (split.axis < 0) return split;
    // Greedy termination (Eq. 4): stay a leaf when no split is cheaper than visiting all points.
    const Vec3 ext = cell.extent() + Vec3(expansion_);
    const double measure = heuristic_ == Heuristic::sah
                               ? static_cast<double>(ext.x) * ext.y +
                                     static_cast<double>(ext.y) * ext.z +
                                     static_cast<double>(ext.z) * ext.x
                               : static_cast<double>(ext.x) * ext.y * ext.z;
    const std::size_t n = e - b;
    const double split_cost = traversal_cost_ + point_cost_ * split.cost / measure;
    if (split_cost >= static_cast<double>(point_cost_) * static_cast<double>(n) &&
        n <= kMaxCostLeaf)
      return {};
    return split;
  }

  // Exact greedy sweep over every distinct coordinate along axis a. Each child's cell is cut
  // at the points nearest the plane (below_max, above_min), as traversal sees it, and grown by
  // the radius on every side. VVH: volume = extent_a × P; SAH: half area = extent_a × S + P.
  // Costs are non-negative floats, so their bits order like unsigned integers: an integer
  // minimum vectorises.
  Split sweep(std::size_t b, std::size_t e, const Aabb& cell, int a, unsigned parity) {
    const int n = static_cast<int>(e - b);
    const float* keys = columns(a, parity).c[a] + b;
    const Vec3 ext = cell.extent() + Vec3(expansion_);
    const float P = ext[(a + 1) % 3] * ext[(a + 2) % 3];
    const bool sah = heuristic_ == Heuristic::sah;
    const float S = sah ? ext[(a + 1) % 3] + ext[(a + 2) % 3] : 1.0f, Q = sah ? P : 0.0f;
    const float lo = cell.lo[a] - expansion_,
                hi = cell.hi[a] + expansion_;  // key - lo: extent + 2r
    const float count = static_cast<float>(n);
    const auto cost_bits = [=](int i) {  // written so that GCC vectorises it
      const float prev = keys[i - 1], key = keys[i], below = static_cast<float>(i);
      const float cost = ((prev - lo) * S + Q) * below + ((hi - key) * S + Q) * (count - below);
      const std::uint32_t same = static_cast<std::uint32_t>(!(key > prev));  // 1: not a candidate
      return std::bit_cast<std::uint32_t>(cost) | (0u - same);
    };
    // (cost bits, position) in one integer: its minimum is the cheapest candidate, ties to the
    // first position, in one vectorised pass.
    std::uint64_t best_key = UINT64_MAX;
    for (int i = 1; i < n; ++i) {
      const std::uint64_t key =
          (static_cast<std::uint64_t>(cost_bits(i)) << 32) | static_cast<std::uint32_t>(i);
      best_key = key < best_key ? key : best_key;
    }
    const auto best = static_cast<std::uint32_t>(best_key >> 32);
    if (best == UINT32_MAX) return {};  // no candidate: no spread (arithmetic NaNs are never ~0)
    const auto pos = static_cast<std::uint32_t>(best_key);
    const double cost = static_cast<double>(std::bit_cast<float>(best)) * (sah ? 1.0f : P);
    return {a, static_cast<std::size_t>(pos), cost};
  }

  // The median of the longest axis, moved to the nearest change of coordinate; axes with no
  // spread are skipped (a node of identical points stays a leaf).
  Split choose_median(std::size_t b, std::size_t e, unsigned parity) {
    const std::size_t n = e - b;
    std::array<int, 3> order{0, 1, 2};
    std::array<float, 3> spread{};
    for (int a = 0; a < 3; ++a) {
      const float* keys = columns(a, parity).c[a];
      spread[a] = keys[e - 1] - keys[b];
    }
    std::ranges::stable_sort(order, [&](int x, int y) { return spread[x] > spread[y]; });
    for (int a : order) {
      if (!(spread[a] > 0)) break;
      const float* keys = columns(a, parity).c[a] + b;
      const std::size_t m = n / 2;
      for (std::size_t d = 0; d <= n; ++d) {  // candidate positions are 1 .. n - 1
        const std::size_t up = m + d, down = m - d;
        if (up < n && keys[up - 1] < keys[up]) return {a, up, 0};
        if (d < m && keys[down - 1] < keys[down]) return {a, down, 0};
        if (up >= n && d >= m) break;
      }
    }
    return {};
  }

  // Splits the node's columns stably: the split axis is already in order; the other two are
  // filtered by coordinate[a] < above_min (exact: no point lies between the planes) into their
  // other buffer. Returns the children's parity.
  unsigned partition(std::size_t b, std::size_t e, int a, float above_min, std::size_t below_count,
                     unsigned parity) {
    const auto move_axis = [&](int j) {
      const Columns from = columns(j, parity);
      const Columns to = columns(j, parity ^ (1u << j));
      const float* split_coord = from.c[a];
      std::size_t below = b, above = b + below_count, i = b;
#if defined(__AVX512F__)
      // 16 at a time: compress each column's lanes for either side and store just those (masked
      // stores: a full store would spill into the other side or a neighbouring node's range).
      const __m512 plane = _mm512_set1_ps(above_min);
      for (; i + 16 <= e; i += 16) {
        const __mmask16 goes_below =
            _mm512_cmp_ps_mask(_mm512_loadu_ps(split_coord + i), plane, _CMP_LT_OQ);
        const __mmask16 goes_above = static_cast<__mmask16>(~goes_below);
        const int nb = std::popcount(static_cast<unsigned>(goes_below));
        const __mmask16 first_below = static_cast<__mmask16>((1u << nb) - 1);
        const __mmask16 first_above = static_cast<__mmask16>((1u << (16 - nb)) - 1);
        for (int m = 0; m < 3; ++m) {
          const __m512 v = _mm512_loadu_ps(from.c[m] + i);
          _mm512_mask_storeu_ps(to.c[m] + below, first_below,
                                _mm512_maskz_compress_ps(goes_below, v));
          _mm512_mask_storeu_ps(to.c[m] + above, first_above,
                                _mm512_maskz_compress_ps(goes_above, v));
        }
        const __m512i ids = _mm512_loadu_si512(from.id + i);
        _mm512_mask_storeu_epi32(to.id + below, first_below,
                                 _mm512_maskz_compress_epi32(goes_below, ids));
        _mm512_mask_storeu_epi32(to.id + above, first_above,
                                 _mm512_maskz_compress_epi32(goes_above, ids));
        below += nb;
        above += 16 - nb;
      }
#endif
      for (; i < e; ++i) {
        const bool goes_below = split_coord[i] < above_min;
        const std::size_t slot = goes_below ? below : above;
        below += goes_below ? 1 : 0;
        above += goes_below ? 0 : 1;
        to.c[0][slot] = from.c[0][i];
        to.c[1][slot] = from.c[1][i];
        to.c[2][slot] = from.c[2][i];
        to.id[slot] = from.id[i];
      }
    };
    const int j0 = (a + 1) % 3, j1 = (a + 2) % 3;
    if (e - b >= kParallelAxes)
      parallel_invoke([&] { move_axis(j0); }, [&] { move_axis(j1); });
    else {
      move_axis(j0);
      move_axis(j1);
    }
    return parity ^ (1u << j0) ^ (1u << j1);
  }

  std::size_t n_;
  Heuristic heuristic_;
  std::size_t leaf_size_;
  float expansion_;  // 2 × the radius: a cell grows by it along every axis
  float traversal_cost_, point_cost_;
  Scratch<float> coords_;       // [axis][buffer][coordinate][point]
  Scratch<std::uint32_t> ids_;  // [axis][buffer][point]
  std::vector<std::uint32_t> permutation_;
};

}  // namespace

PointBuildOutput build_point_tree(std::span<const Vec3> points, const Aabb& bounds,
                                  const PointTreeConfig& config, float radius) {
  Builder builder(points, config, radius);
  builder.prepare_permutation();
  PointBuildOutput out;
  out.nodes.reserve(4 * points.size() / std::max(1, config.leaf_size) + 16);
  builder.build(out.nodes, 0, points.size(), bounds, 0, 0u);
  out.permutation = builder.take_permutation();
  return out;
}

double vvh_cell_volume(const Aabb& cell, float radius) {
  const Vec3 e = cell.extent() + Vec3(2 * radius);
  return static_cast<double>(e.x) * e.y * e.z;
}

double vvh_tree_cost(std::span<const PointNode> nodes, const Aabb& bounds,
                     const PointTreeConfig& config, float radius) {
  const auto volume = [&](const Aabb& cell) { return vvh_cell_volume(cell, radius); };
  const double root_volume = volume(bounds);
  if (!(root_volume > 0)) return 0;
  struct Entry {
    std::uint32_t node;
    Aabb cell;
  };
  std::vector<Entry> stack{{0, bounds}};
  double cost = 0;
  while (!stack.empty()) {
    const Entry entry = stack.back();
    stack.pop_back();
    const PointNode& node = nodes[entry.node];
    const double weight = volume(entry.cell) / root_volume;
    if (node.is_leaf()) {
      cost += weight * config.point_cost * node.count();
      continue;
    }
    cost += weight * config.traversal_cost;
    Aabb below = entry.cell, above = entry.cell;
    below.hi[node.axis()] = node.below_max;
    above.lo[node.axis()] = node.above_min;
    stack.push_back({entry.node + 1, below});
    stack.push_back({entry.node + node.index, above});
  }
  return cost;
}

}  // namespace splitray

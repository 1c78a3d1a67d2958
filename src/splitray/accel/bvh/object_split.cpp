#include "splitray/accel/bvh/object_split.hpp"

#include <algorithm>
#include <array>
#include <limits>
#include <utility>
#include <vector>

#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

// Large spans are binned in parallel; min/max and integer counts merge exactly, so the
// result is the same for every split of the work.
constexpr std::size_t kParallelRefs = 32768;
constexpr int kMaxBins = 256;

// Raw storage: only the bins in use are initialised (nodes are many, bins mostly few).
struct Bin {
  float lo[3], hi[3];
  std::uint32_t count;
  void clear() {
    for (int k = 0; k < 3; ++k)
      lo[k] = std::numeric_limits<float>::infinity(),
      hi[k] = -std::numeric_limits<float>::infinity();
    count = 0;
  }
  void add(const Aabb& b) {
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], b.lo[k]), hi[k] = std::max(hi[k], b.hi[k]);
    ++count;
  }
  void merge(const Bin& o) {
    for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], o.lo[k]), hi[k] = std::max(hi[k], o.hi[k]);
    count += o.count;
  }
  Aabb box() const { return {{lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}}; }
};

struct Bins {
  int n = 0;
  Bin axis[3][kMaxBins];

  explicit Bins(int count) : n(count) {
    for (auto& a : axis)
      for (int i = 0; i < n; ++i) a[i].clear();
  }
  void add(const CenterBins& map, const BvhRef& r) {
    for (int a = 0; a < 3; ++a) axis[a][map.bin(r, a)].add(r.box);
  }
  void merge(const Bins& o) {
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < n; ++i) axis[a][i].merge(o.axis[a][i]);
  }
};

}  // namespace

RefBounds ref_bounds(std::span<const BvhRef> refs) {
  const auto chunk = [&](std::size_t begin, std::size_t end) {
    RefBoundsAccumulator b;
    for (std::size_t i = begin; i < end; ++i) b.add(refs[i]);
    return b.bounds();
  };
  if (refs.size() < kParallelRefs) return chunk(0, refs.size());
  return parallel_reduce(
      refs.size(), 8192, RefBounds{},
      [&](std::size_t begin, std::size_t end, RefBounds& acc) { acc.extend(chunk(begin, end)); },
      [](RefBounds& total, const RefBounds& part) { total.extend(part); });
}

CenterBins::CenterBins(const Aabb& centers, int bins)
    : lo(centers.lo), count(std::clamp(bins, 2, kMaxBins)) {
  const Vec3 e = centers.extent();
  for (int a = 0; a < 3;
       ++a)  // slightly below count / extent: the top centre stays in the last bin
    scale[a] = e[a] > 0 ? static_cast<float>(count) * (1 - 0x1p-20f) / e[a] : 0.0f;
}

int CenterBins::bin(const BvhRef& r, int axis) const {
  const float c = (r.box.lo[axis] + r.box.hi[axis]) * 0.5f;
  const int b = static_cast<int>((c - lo[axis]) * scale[axis]);
  return std::clamp(b, 0, count - 1);
}

ObjectSplit find_object_split(std::span<const BvhRef> refs, const RefBounds& bounds,
                              const BvhBuildOptions& options, std::uint64_t& evals) {
  ObjectSplit best;
  const CenterBins map(bounds.centers, bin_count(options, refs.size()));
  const int n_bins = map.count;

  const auto bin_all = [&](std::size_t begin, std::size_t end, Bins& bins) {
    for (std::size_t i = begin; i < end; ++i) bins.add(map, refs[i]);
  };
  const bool parallel = refs.size() >= kParallelRefs;
  Bins local(parallel ? 0 : n_bins);
  std::unique_ptr<Bins> merged;  // the parallel reduction's result
  const Bins* bins = &local;
  if (!parallel) {
    bin_all(0, refs.size(), local);
  } else {
    merged = std::make_unique<Bins>(
        parallel_reduce(refs.size(), 8192, Bins(n_bins), bin_all,
                        [](Bins& total, const Bins& part) { total.merge(part); }));
    bins = merged.get();
  }

  const float parent_area = std::max(bounds.box.half_area(), std::numeric_limits<float>::min());
  std::array<float, kMaxBins> right_area;
  std::array<Aabb, kMaxBins> right_box;
  best.cost = std::numeric_limits<float>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (map.scale[a] == 0) continue;
    const auto& axis_bins = bins->axis[a];
    Aabb acc;
    for (int i = n_bins - 1; i > 0; --i) {
      acc.extend(axis_bins[i].box());
      right_box[i] = acc;
      right_area[i] = acc.half_area();
    }
    Aabb left;
    std::size_t n_left = 0;
    for (int i = 0; i < n_bins - 1; ++i) {
      left.extend(axis_bins[i].box());
      n_left += axis_bins[i].count;
      const std::size_t n_right = refs.size() - n_left;
      if (n_left == 0 || n_right == 0) continue;
      ++evals;
      const float cost = bvh_split_cost(options, parent_area, left.half_area(), n_left,
                                        right_area[i + 1], n_right);
      if (cost < best.cost) {
        best.cost = cost;
        best.axis = a;
        best.bin = i;
        best.left = left;
        best.right = right_box[i + 1];
      }
    }
  }
  return best;
}

std::size_t partition_refs(std::span<BvhRef> refs, const CenterBins& bins, const ObjectSplit& split,
                           RefBounds& left, RefBounds& right) {
  const auto goes_left = [&](const BvhRef& r) { return bins.bin(r, split.axis) <= split.bin; };
  RefBoundsAccumulator l, r;
  std::size_t i = 0, j = refs.size();
  for (;;) {
    while (i < j && goes_left(refs[i])) l.add(refs[i++]);
    while (i < j && !goes_left(refs[j - 1])) r.add(refs[--j]);
    if (i >= j) break;
    std::swap(refs[i], refs[j - 1]);
    l.add(refs[i++]);
    r.add(refs[--j]);
  }
  left.extend(l.bounds());
  right.extend(r.bounds());
  return i;
}

}  // namespace splitray

#include "splitray/accel/bvh/object_split.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <limits>
#include <utility>
#include <vector>

namespace splitray {

namespace {

// Large spans are binned in parallel; min/max and integer counts merge exactly, so the
// result is the same for every split of the work.
constexpr std::size_t kParallelRefs = 32768;
constexpr int kMaxBins = 256;

struct Bin {
  Aabb box;
  std::uint32_t count = 0;
};

struct Bins {
  int n = 0;
  std::array<std::array<Bin, kMaxBins>, 3> axis;

  void add(const CenterBins& map, const PrimRef& r) {
    for (int a = 0; a < 3; ++a) {
      Bin& b = axis[a][map.bin(r, a)];
      b.box.extend(r.box);
      ++b.count;
    }
  }
  void merge(const Bins& o) {
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < n; ++i) {
        axis[a][i].box.extend(o.axis[a][i].box);
        axis[a][i].count += o.axis[a][i].count;
      }
  }
};

}  // namespace

RefBounds ref_bounds(std::span<const PrimRef> refs) {
  const auto chunk = [&](std::size_t begin, std::size_t end) {
    RefBounds b;
    for (std::size_t i = begin; i < end; ++i) b.extend(refs[i]);
    return b;
  };
  if (refs.size() < kParallelRefs) return chunk(0, refs.size());
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, refs.size(), 8192), RefBounds{},
      [&](const tbb::blocked_range<std::size_t>& r, RefBounds acc) {
        acc.extend(chunk(r.begin(), r.end()));
        return acc;
      },
      [](RefBounds a, const RefBounds& b) {
        a.extend(b);
        return a;
      });
}

CenterBins::CenterBins(const Aabb& centers, int bins) : lo(centers.lo), count(std::clamp(bins, 2, kMaxBins)) {
  const Vec3 e = centers.extent();
  for (int a = 0; a < 3; ++a)  // slightly below count / extent: the top centre stays in the last bin
    scale[a] = e[a] > 0 ? static_cast<float>(count) * (1 - 0x1p-20f) / e[a] : 0.0f;
}

int CenterBins::bin(const PrimRef& r, int axis) const {
  const float c = (r.box.lo[axis] + r.box.hi[axis]) * 0.5f;
  const int b = static_cast<int>((c - lo[axis]) * scale[axis]);
  return std::clamp(b, 0, count - 1);
}

ObjectSplit find_object_split(std::span<const PrimRef> refs, const RefBounds& bounds,
                              const BvhBuildOptions& options, std::uint64_t& evals) {
  ObjectSplit best;
  const CenterBins map(bounds.centers, options.bins);
  const int n_bins = map.count;

  auto bins = std::make_unique<Bins>();
  bins->n = n_bins;
  if (refs.size() < kParallelRefs) {
    for (const PrimRef& r : refs) bins->add(map, r);
  } else {
    *bins = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, refs.size(), 8192), *bins,
        [&](const tbb::blocked_range<std::size_t>& range, Bins acc) {
          for (std::size_t i = range.begin(); i < range.end(); ++i) acc.add(map, refs[i]);
          return acc;
        },
        [](Bins a, const Bins& b) {
          a.merge(b);
          return a;
        });
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
      acc.extend(axis_bins[i].box);
      right_box[i] = acc;
      right_area[i] = acc.half_area();
    }
    Aabb left;
    std::size_t n_left = 0;
    for (int i = 0; i < n_bins - 1; ++i) {
      left.extend(axis_bins[i].box);
      n_left += axis_bins[i].count;
      const std::size_t n_right = refs.size() - n_left;
      if (n_left == 0 || n_right == 0) continue;
      ++evals;
      const float cost = split_cost(options, parent_area, left.half_area(), n_left, right_area[i + 1], n_right);
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

std::size_t partition_refs(std::span<PrimRef> refs, const CenterBins& bins, const ObjectSplit& split,
                           RefBounds& left, RefBounds& right) {
  const auto goes_left = [&](const PrimRef& r) { return bins.bin(r, split.axis) <= split.bin; };
  std::size_t i = 0, j = refs.size();
  for (;;) {
    while (i < j && goes_left(refs[i])) left.extend(refs[i++]);
    while (i < j && !goes_left(refs[j - 1])) right.extend(refs[--j]);
    if (i >= j) break;
    std::swap(refs[i], refs[j - 1]);
    left.extend(refs[i++]);
    right.extend(refs[--j]);
  }
  return i;
}

}  // namespace splitray

#pragma once
// Binned SAH object splits over reference centres, shared by the binned builder and SBVH.
#include <cstddef>
#include <cstdint>
#include <algorithm>
#include <span>

#include "splitray/accel/bvh/bvh_build.hpp"

namespace splitray {

// Bounds of a set of references and of their centres.
struct RefBounds {
  Aabb box, centers;
  void extend(const BvhRef& r) {
    box.extend(r.box);
    centers.extend(r.center());
  }
  void extend(const RefBounds& o) {
    box.extend(o.box);
    centers.extend(o.centers);
  }
};

RefBounds ref_bounds(std::span<const BvhRef> refs);  // parallel for large spans

// Which bin of `axis` a centre falls in: the mapping both binning and partitioning use.
struct CenterBins {
  Vec3 lo, scale;
  int count;
  CenterBins(const Aabb& centers, int bins);
  int bin(const BvhRef& r, int axis) const;
};

struct ObjectSplit {
  int axis = -1;      // -1: no split (all centres coincide)
  int bin = 0;        // references whose centre bin <= bin go left
  float cost = 0;     // K_T + K_I * (A_L N_L + A_R N_R) / A
  Aabb left, right;   // bounds of the two sides
};

// Bins for n references: fewer for small nodes, where more would stay empty.
inline int bin_count(const BvhBuildOptions& options, std::size_t n) {
  return static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(options.bins), 2 * n + 4));
}

// The cheapest binned split of `refs` (bounds `bounds`); `evals` counts cost evaluations.
ObjectSplit find_object_split(std::span<const BvhRef> refs, const RefBounds& bounds,
                              const BvhBuildOptions& options, std::uint64_t& evals);

// Moves the references whose centre bin on split.axis is <= split.bin to the front and
// (bins = CenterBins(bounds.centers, bin_count(options, refs.size())), as in the search)
// returns their number, with the bounds of both sides.
std::size_t partition_refs(std::span<BvhRef> refs, const CenterBins& bins, const ObjectSplit& split,
                           RefBounds& left, RefBounds& right);

// SAH cost of a split with the given child areas and counts, relative to the parent's area.
inline float split_cost(const BvhBuildOptions& o, float parent_area, float left_area, std::size_t n_left,
                        float right_area, std::size_t n_right) {
  return o.traversal_cost + o.intersection_cost *
                                (left_area * static_cast<float>(n_left) + right_area * static_cast<float>(n_right)) /
                                parent_area;
}

}  // namespace splitray

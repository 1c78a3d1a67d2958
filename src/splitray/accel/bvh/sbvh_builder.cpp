// Spatial-split BVH (Stich, Friedrich & Dietrich, "Spatial Splits in Bounding Volume
// Hierarchies", HPG 2009). Every node tries a binned object split; where its two children
// would overlap by more than alpha times the root's area and sbvh_overlap times the node's, it
// also bins the node's box in space (spatial_split.hpp) and takes the cheaper of the two. A
// spatial split sends each straddling reference to both sides, clipped, unless moving it whole
// to one side is cheaper (reference unsplitting, §4.4). References are split at planes by the
// conservative clip of accel/triangle_clip.hpp (split_triangle_bounds).
//
// The references live in one array with room for the references spatial splits add (as in
// Embree's builder): a node's are [begin, end) and it may grow up to cap; a split gives each
// child a share of the room in proportion to its references, so object splits partition in
// place and nothing is allocated per node.

#include <algorithm>
#include <atomic>
#include <memory>
#include <new>

#include "splitray/accel/bvh/bvh_build.hpp"
#include "splitray/accel/bvh/object_split.hpp"
#include "splitray/accel/bvh/spatial_split.hpp"
#include "splitray/accel/triangle_clip.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

constexpr double kGrowth = 1.5;  // at most 1.5 times as many references as input

// A node's references [begin, end) of the array, which it may grow up to cap.
struct Range {
  std::size_t begin, end, cap;
  std::size_t size() const { return end - begin; }
};

class SbvhBuilder {
 public:
  SbvhBuilder(std::span<const Triangle> triangles, const BvhBuildOptions& options, const Aabb& root,
              BvhRef* refs)
      : tris_(triangles),
        options_(options),
        min_overlap_(options.sbvh_alpha * root.half_area()),
        refs_(refs),
        task_refs_(bvh_task_refs(triangles.size())) {}

  std::unique_ptr<BvhPiece> build_piece(const Range& range, const RefBounds& bounds, int depth) {
    auto piece = std::make_unique<BvhPiece>();
    piece->nodes.resize(1);
    std::uint64_t evals = 0;
    build(*piece, 0, range, bounds, depth, evals);
    evals_ += evals;
    return piece;
  }

  std::uint64_t evals() const { return evals_; }

 private:
  std::span<BvhRef> refs(const Range& r) const { return {refs_ + r.begin, r.size()}; }

  void make_leaf(BvhPiece& piece, std::size_t slot, const Range& range, const Aabb& box) {
    // A triangle split earlier may come back in two parts: reference it once.
    const auto first = static_cast<std::uint32_t>(piece.prims.size());
    for (const BvhRef& r : refs(range)) piece.prims.push_back(r.prim);
    std::sort(piece.prims.begin() + first, piece.prims.end());
    piece.prims.erase(std::unique(piece.prims.begin() + first, piece.prims.end()),
                      piece.prims.end());
    piece.nodes[slot] =
        BvhNode::make_leaf(box, first, static_cast<std::uint32_t>(piece.prims.size() - first));
  }

  // Spatial splits are tried where the object split's children overlap by more than alpha of
  // the root's area and sbvh_overlap of the node's (Embree's second test: most nodes overlap a
  // little, the search costs tens of times an object split there and rarely wins).
  bool spatial_may_pay(const ObjectSplit& object, const Aabb& box) const {
    const float overlap = intersection(object.left, object.right).half_area();
    return overlap > min_overlap_ && overlap >= options_.sbvh_overlap * box.half_area();
  }

  // Distributes refs by the plane, with the bounds of each side; false when one side would
  // stay empty.
  bool spatial_partition(std::span<const BvhRef> refs, const SpatialSplit& split,
                         std::vector<BvhRef>& left, std::vector<BvhRef>& right,
                         RefBounds& left_bounds, RefBounds& right_bounds) const {
    const int a = split.axis;
    const float p = split.plane;
    Aabb left_box = split.left, right_box = split.right;
    auto n_left = static_cast<float>(split.n_left), n_right = static_cast<float>(split.n_right);
    RefBoundsAccumulator lb, rb;
    const auto to_left = [&](const BvhRef& r) { left.push_back(r), lb.add(r); };
    const auto to_right = [&](const BvhRef& r) { right.push_back(r), rb.add(r); };
    for (const BvhRef& r : refs) {
      if (r.box.hi[a] <= p) {
        to_left(r);
      } else if (r.box.lo[a] >= p) {
        to_right(r);
      } else {
        const SplitMeasure& m = options_.measure;
        const float both = m(left_box) * n_left + m(right_box) * n_right;
        const float all_left = m(merge(left_box, r.box)) * n_left + m(right_box) * (n_right - 1);
        const float all_right = m(left_box) * (n_left - 1) + m(merge(right_box, r.box)) * n_right;
        if (all_left < both && all_left <= all_right) {
          to_left(r);
          left_box.extend(r.box);
          n_right -= 1;
        } else if (all_right < both) {
          to_right(r);
          right_box.extend(r.box);
          n_left -= 1;
        } else {
          Aabb l, h;
          split_triangle_bounds(tris_[r.prim], r.box, a, p, l, h);
          if (!l.empty()) to_left({l, r.prim});
          if (!h.empty()) to_right({h, r.prim});
        }
      }
    }
    left_bounds = lb.bounds();
    right_bounds = rb.bounds();
    return !left.empty() && !right.empty();
  }

  // Splits `range` by a spatial split into the children's ranges; false (nothing moved) when
  // the split would leave a side empty, not shrink, or outgrow the range's room.
  bool split_spatial(const Range& range, const SpatialSplit& split, Range& left, Range& right,
                     RefBounds& left_bounds, RefBounds& right_bounds) {
    // Per-thread scratch, used with no parallel construct running inside (a waiting thread
    // may run another task on the same scratch).
    thread_local std::vector<BvhRef> left_refs, right_refs;
    left_refs.clear();
    right_refs.clear();
    const std::size_t n = range.size(), room = range.cap - range.begin;
    RefBounds l, r;  // set only on success: the object split that then runs extends them
    if (!spatial_partition(refs(range), split, left_refs, right_refs, l, r) ||
        left_refs.size() >= n || right_refs.size() >= n ||
        left_refs.size() + right_refs.size() > room)
      return false;
    left_bounds = l;
    right_bounds = r;
    divide(range, left_refs.size(), right_refs.size(), left, right);
    std::copy(left_refs.begin(), left_refs.end(), refs_ + left.begin);
    std::copy(right_refs.begin(), right_refs.end(), refs_ + right.begin);
    return true;
  }

  // The children's ranges: each gets the room left over in proportion to its references.
  static void divide(const Range& range, std::size_t n_left, std::size_t n_right, Range& left,
                     Range& right) {
    const std::size_t room = range.cap - range.begin, used = n_left + n_right;
    const std::size_t spare = room - used;
    const std::size_t left_room =
        n_left + static_cast<std::size_t>(static_cast<double>(spare) * static_cast<double>(n_left) /
                                          static_cast<double>(used));
    left = {range.begin, range.begin + n_left, range.begin + left_room};
    right = {left.cap, left.cap + n_right, range.cap};
  }

  void build(BvhPiece& piece, std::size_t slot, const Range& range, const RefBounds& bounds,
             int depth, std::uint64_t& evals) {
    const std::size_t n = range.size(), room = range.cap - range.begin;
    if (bvh_leaf_at_once(options_, n, bounds.box, depth))
      return make_leaf(piece, slot, range, bounds.box);

    const ObjectSplit object = find_object_split(refs(range), bounds, options_, evals);
    SpatialSplit spatial;
    if (room > n && (object.axis < 0 || spatial_may_pay(object, bounds.box)))
      spatial = find_spatial_split(refs(range), tris_, bounds.box, options_, evals);
    // A node that may be a leaf is split only by a split cheaper than the leaf: the spatial
    // split when it beats both, else the object split (or halving, when every centre
    // coincides). A spatial split can fail to be made (in nodes a few float steps thick its
    // estimate is rounding); the object split then had to beat the leaf too, which it was once
    // not asked (conference room: 10,203 such splits).
    const bool small = n <= static_cast<std::size_t>(options_.max_leaf);
    const float leaf_cost = bvh_leaf_cost(options_, n);
    Range left, right;
    RefBounds left_bounds, right_bounds;
    int axis = 0;
    const bool spatial_done = spatial.axis >= 0 &&
                              (object.axis < 0 || spatial.cost < object.cost) &&
                              (!small || spatial.cost < leaf_cost) &&
                              split_spatial(range, spatial, left, right, left_bounds, right_bounds);
    if (spatial_done) {
      axis = spatial.axis;
    } else if (small && !(object.axis >= 0 && object.cost < leaf_cost)) {
      return make_leaf(piece, slot, range, bounds.box);
    } else {
      std::size_t n_left = n / 2;
      const std::span<BvhRef> node_refs = refs(range);
      if (object.axis >= 0) {
        const CenterBins map(bounds.centers, bin_count(options_, n));
        n_left = n >= kParallelSplitRefs
                     ? partition_refs_parallel(node_refs, map, object, left_bounds, right_bounds)
                     : partition_refs(node_refs, map, object, left_bounds, right_bounds);
        axis = object.axis;
      } else {  // all centres coincide: halve the list
        for (std::size_t i = 0; i < n; ++i)
          (i < n_left ? left_bounds : right_bounds).extend(node_refs[i]);
      }
      divide(range, n_left, n - n_left, left, right);
      // The right side moves up by the left's room: its first references go to its end.
      const std::size_t shift = right.begin - (range.begin + n_left);
      const std::size_t moved = std::min(shift, right.size());
      std::copy_n(refs_ + range.begin + n_left, moved, refs_ + right.end - moved);
    }

    if (slot == 0 && piece.nodes.size() == 1 && n >= task_refs_) {
      piece.nodes[0] = BvhNode::make_interior(bounds.box, axis);
      parallel_invoke([&] { piece.kids[0] = build_piece(left, left_bounds, depth + 1); },
                      [&] { piece.kids[1] = build_piece(right, right_bounds, depth + 1); });
      return;
    }
    const auto pair = static_cast<std::uint32_t>(piece.nodes.size());
    piece.nodes.resize(pair + 2);
    piece.nodes[slot] = BvhNode::make_interior(bounds.box, axis, pair);
    build(piece, pair, left, left_bounds, depth + 1, evals);
    build(piece, pair + 1, right, right_bounds, depth + 1, evals);
  }

  std::span<const Triangle> tris_;
  const BvhBuildOptions& options_;
  float min_overlap_;
  BvhRef* refs_;
  const std::size_t task_refs_;  // subtrees at least this big become tasks
  std::atomic<std::uint64_t> evals_{0};
};

}  // namespace

BvhBuildResult build_bvh_sbvh(std::span<const Triangle> triangles, std::vector<BvhRef> refs,
                              const RefBounds& bounds, const BvhBuildOptions& options) {
  const std::size_t n = refs.size();
  const auto room = std::max(n, static_cast<std::size_t>(kGrowth * static_cast<double>(n)));
  // Raw storage (BvhRef is an implicit-lifetime aggregate): the room is written only where
  // spatial splits use it.
  const std::unique_ptr<BvhRef, void (*)(BvhRef*)> array(
      static_cast<BvhRef*>(
          ::operator new (room * sizeof(BvhRef), std::align_val_t{alignof(BvhRef)})),
      [](BvhRef* p) { ::operator delete (p, std::align_val_t{alignof(BvhRef)}); });
  parallel_chunks(n, 16384, [&](std::size_t begin, std::size_t end) {
    std::copy(refs.begin() + static_cast<std::ptrdiff_t>(begin),
              refs.begin() + static_cast<std::ptrdiff_t>(end), array.get() + begin);
  });
  std::vector<BvhRef>().swap(refs);
  SbvhBuilder builder(triangles, options, bounds.box, array.get());
  BvhBuildResult result;
  result.root = builder.build_piece({0, n, room}, bounds, 0);
  result.cost_evals = builder.evals();
  return result;
}

}  // namespace splitray

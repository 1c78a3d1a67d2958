// Binned SAH BVH: references partitioned in place (large nodes binned and partitioned in
// parallel), subtrees above a size built as parallel tasks into pieces of their own (the
// layout never depends on the thread count).

#include <algorithm>
#include <atomic>

#include "splitray/accel/bvh/bvh_build.hpp"
#include "splitray/accel/bvh/object_split.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

class BinnedBuilder {
 public:
  BinnedBuilder(std::vector<BvhRef>& refs, const BvhBuildOptions& options)
      : refs_(refs), options_(options), task_refs_(bvh_task_refs(refs.size())) {}

  std::unique_ptr<BvhPiece> build_piece(std::size_t begin, std::size_t end, const RefBounds& bounds,
                                        int depth) {
    auto piece = std::make_unique<BvhPiece>();
    piece->nodes.resize(1);
    std::uint64_t evals = 0;
    build(*piece, 0, begin, end, bounds, depth, evals);
    evals_ += evals;
    return piece;
  }

  std::uint64_t evals() const { return evals_; }

 private:
  void make_leaf(BvhPiece& piece, std::size_t slot, std::size_t begin, std::size_t end,
                 const Aabb& box) {
    const auto first = static_cast<std::uint32_t>(piece.prims.size());
    for (std::size_t i = begin; i < end; ++i) piece.prims.push_back(refs_[i].prim);
    piece.nodes[slot] = BvhNode::make_leaf(box, first, static_cast<std::uint32_t>(end - begin));
  }

  void build(BvhPiece& piece, std::size_t slot, std::size_t begin, std::size_t end,
             const RefBounds& bounds, int depth, std::uint64_t& evals) {
    const std::size_t n = end - begin;
    if (bvh_leaf_at_once(options_, n, bounds.box, depth))
      return make_leaf(piece, slot, begin, end, bounds.box);

    const std::span<BvhRef> refs(refs_.data() + begin, n);
    const ObjectSplit split = find_object_split(refs, bounds, options_, evals);
    const float leaf_cost = bvh_leaf_cost(options_, n);
    const bool small = n <= static_cast<std::size_t>(options_.max_leaf);
    if (small && (split.axis < 0 || split.cost >= leaf_cost))
      return make_leaf(piece, slot, begin, end, bounds.box);

    RefBounds left, right;
    std::size_t n_left;
    int axis;
    if (split.axis >= 0) {
      const CenterBins map(bounds.centers, bin_count(options_, n));
      n_left = n >= kParallelSplitRefs ? partition_refs_parallel(refs, map, split, left, right)
                                       : partition_refs(refs, map, split, left, right);
      axis = split.axis;
    } else {  // all centres coincide: halve the list
      n_left = n / 2;
      for (std::size_t i = 0; i < n; ++i) (i < n_left ? left : right).extend(refs[i]);
      axis = 0;
    }
    const std::size_t mid = begin + n_left;

    if (slot == 0 && piece.nodes.size() == 1 && n >= task_refs_) {
      piece.nodes[0] = BvhNode::make_interior(bounds.box, axis);
      parallel_invoke([&] { piece.kids[0] = build_piece(begin, mid, left, depth + 1); },
                      [&] { piece.kids[1] = build_piece(mid, end, right, depth + 1); });
      return;
    }
    const auto pair = static_cast<std::uint32_t>(piece.nodes.size());
    piece.nodes.resize(pair + 2);
    piece.nodes[slot] = BvhNode::make_interior(bounds.box, axis, pair);
    build(piece, pair, begin, mid, left, depth + 1, evals);
    build(piece, pair + 1, mid, end, right, depth + 1, evals);
  }

  std::vector<BvhRef>& refs_;
  const BvhBuildOptions& options_;
  const std::size_t task_refs_;  // subtrees at least this big become tasks
  std::atomic<std::uint64_t> evals_{0};
};

}  // namespace

std::vector<BvhRef> make_prim_refs(std::span<const Triangle> triangles) {
  std::vector<BvhRef> refs(triangles.size());
  parallel_chunks(triangles.size(), 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      refs[i] = {triangles[i].bounds(), static_cast<std::uint32_t>(i)};
  });
  return refs;
}

BvhBuildResult build_bvh_binned(std::span<const Triangle>, std::vector<BvhRef> refs,
                                const RefBounds& bounds, const BvhBuildOptions& options) {
  BinnedBuilder builder(refs, options);
  BvhBuildResult result;
  result.root = builder.build_piece(0, refs.size(), bounds, 0);
  result.cost_evals = builder.evals();
  return result;
}

}  // namespace splitray

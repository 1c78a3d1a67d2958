// Spatial-split BVH (Stich, Friedrich & Dietrich, "Spatial Splits in Bounding Volume
// Hierarchies", HPG 2009). Every node tries a binned object split; where its two children
// would overlap by more than alpha times the root's area and sbvh_overlap times the node's, it
// also bins the node's box in space (spatial_split.hpp) and takes the cheaper of the two. A spatial
// split sends each straddling reference to both sides, clipped, unless moving it whole to one
// side is cheaper (reference unsplitting, §4.4). References are split at planes by the
// conservative clip of accel/triangle_clip.hpp (split_triangle_bounds).

#include <algorithm>
#include <atomic>
#include <limits>

#include "splitray/accel/bvh/bvh_build.hpp"
#include "splitray/accel/bvh/object_split.hpp"
#include "splitray/accel/bvh/spatial_split.hpp"
#include "splitray/accel/triangle_clip.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

constexpr std::size_t kTaskRefs = 4096;
constexpr double kGrowth = 2.0;  // at most twice as many references as input

class SbvhBuilder {
 public:
  SbvhBuilder(std::span<const Triangle> triangles, const BvhBuildOptions& options, const Aabb& root)
      : tris_(triangles), options_(options), min_overlap_(options.sbvh_alpha * root.half_area()) {}

  std::unique_ptr<BvhPiece> build_piece(std::vector<BvhRef> refs, const RefBounds& bounds,
                                        int depth, std::size_t budget) {
    auto piece = std::make_unique<BvhPiece>();
    piece->nodes.resize(1);
    std::uint64_t evals = 0;
    build(*piece, 0, refs, bounds, depth, budget, evals);
    evals_ += evals;
    return piece;
  }

  std::uint64_t evals() const { return evals_; }

 private:
  void make_leaf(BvhPiece& piece, std::size_t slot, const std::vector<BvhRef>& refs,
                 const Aabb& box) {
    // A triangle split earlier may come back in two parts: reference it once.
    const auto first = static_cast<std::uint32_t>(piece.prims.size());
    for (const BvhRef& r : refs) piece.prims.push_back(r.prim);
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

  // Distributes refs by the plane; false when one side would stay empty.
  bool spatial_partition(const std::vector<BvhRef>& refs, const SpatialSplit& split,
                         std::vector<BvhRef>& left, std::vector<BvhRef>& right) const {
    const int a = split.axis;
    const float p = split.plane;
    Aabb left_box = split.left, right_box = split.right;
    auto n_left = static_cast<float>(split.n_left), n_right = static_cast<float>(split.n_right);
    left.reserve(split.n_left);
    right.reserve(split.n_right);
    for (const BvhRef& r : refs) {
      if (r.box.hi[a] <= p) {
        left.push_back(r);
      } else if (r.box.lo[a] >= p) {
        right.push_back(r);
      } else {
        const float both = left_box.half_area() * n_left + right_box.half_area() * n_right;
        const float all_left =
            merge(left_box, r.box).half_area() * n_left + right_box.half_area() * (n_right - 1);
        const float all_right =
            left_box.half_area() * (n_left - 1) + merge(right_box, r.box).half_area() * n_right;
        if (all_left < both && all_left <= all_right) {
          left.push_back(r);
          left_box.extend(r.box);
          n_right -= 1;
        } else if (all_right < both) {
          right.push_back(r);
          right_box.extend(r.box);
          n_left -= 1;
        } else {
          Aabb lb, rb;
          split_triangle_bounds(tris_[r.prim], r.box, a, p, lb, rb);
          if (!lb.empty()) left.push_back({lb, r.prim});
          if (!rb.empty()) right.push_back({rb, r.prim});
        }
      }
    }
    return !left.empty() && !right.empty();
  }

  // `budget` bounds the references this subtree may hold (spatial splits add some), so that
  // the total stays within kGrowth times the input and the recursion always shrinks.
  void build(BvhPiece& piece, std::size_t slot, std::vector<BvhRef>& refs, const RefBounds& bounds,
             int depth, std::size_t budget, std::uint64_t& evals) {
    const std::size_t n = refs.size();
    if (n <= static_cast<std::size_t>(options_.min_leaf) || depth >= options_.max_depth)
      return make_leaf(piece, slot, refs, bounds.box);

    const ObjectSplit object = find_object_split(refs, bounds, options_, evals);
    SpatialSplit spatial;
    if (budget > n && (object.axis < 0 || spatial_may_pay(object, bounds.box)))
      spatial = find_spatial_split(refs, tris_, bounds.box, options_, evals);
    const float best_cost = std::min(
        object.axis >= 0 ? object.cost : std::numeric_limits<float>::infinity(), spatial.cost);
    const float leaf_cost = bvh_leaf_cost(options_, n);
    if (n <= static_cast<std::size_t>(options_.max_leaf) && !(best_cost < leaf_cost))
      return make_leaf(piece, slot, refs, bounds.box);

    std::vector<BvhRef> left, right;
    RefBounds left_bounds, right_bounds;
    int axis = 0;
    bool done = false;
    if (spatial.axis >= 0 && (object.axis < 0 || spatial.cost < object.cost)) {
      done = spatial_partition(refs, spatial, left, right) && left.size() < n && right.size() < n &&
             left.size() + right.size() <= budget;
      if (done) {
        axis = spatial.axis;
        left_bounds = ref_bounds(left);
        right_bounds = ref_bounds(right);
      } else {
        left.clear();
        right.clear();
      }
    }
    if (!done) {
      std::size_t n_left = n / 2;
      if (object.axis >= 0) {
        n_left = partition_refs(refs, CenterBins(bounds.centers, bin_count(options_, n)), object,
                                left_bounds, right_bounds);
        axis = object.axis;
      } else {
        for (std::size_t i = 0; i < n; ++i)
          (i < n_left ? left_bounds : right_bounds).extend(refs[i]);
      }
      left.assign(refs.begin(), refs.begin() + static_cast<std::ptrdiff_t>(n_left));
      right.assign(refs.begin() + static_cast<std::ptrdiff_t>(n_left), refs.end());
    }
    std::vector<BvhRef>().swap(refs);  // release the parent's references before recursing
    // The spare budget goes to the children in proportion to their references.
    const std::size_t used = left.size() + right.size(), spare = budget > used ? budget - used : 0;
    const std::size_t left_budget =
        left.size() +
        static_cast<std::size_t>(static_cast<double>(spare) * static_cast<double>(left.size()) /
                                 static_cast<double>(used));
    const std::size_t right_budget = std::max(used + spare - left_budget, right.size());

    if (slot == 0 && piece.nodes.size() == 1 && n >= kTaskRefs) {
      piece.nodes[0] = BvhNode::make_interior(bounds.box, axis);
      parallel_invoke(
          [&] {
            piece.kids[0] = build_piece(std::move(left), left_bounds, depth + 1, left_budget);
          },
          [&] {
            piece.kids[1] = build_piece(std::move(right), right_bounds, depth + 1, right_budget);
          });
      return;
    }
    const auto pair = static_cast<std::uint32_t>(piece.nodes.size());
    piece.nodes.resize(pair + 2);
    piece.nodes[slot] = BvhNode::make_interior(bounds.box, axis, pair);
    build(piece, pair, left, left_bounds, depth + 1, left_budget, evals);
    build(piece, pair + 1, right, right_bounds, depth + 1, right_budget, evals);
  }

  std::span<const Triangle> tris_;
  const BvhBuildOptions& options_;
  float min_overlap_;
  std::atomic<std::uint64_t> evals_{0};
};

}  // namespace

BvhBuildResult build_bvh_sbvh(std::span<const Triangle> triangles, std::vector<BvhRef> refs,
                              const BvhBuildOptions& options) {
  const RefBounds bounds = ref_bounds(refs);
  SbvhBuilder builder(triangles, options, bounds.box);
  BvhBuildResult result;
  const std::size_t budget = static_cast<std::size_t>(kGrowth * static_cast<double>(refs.size()));
  result.root = builder.build_piece(std::move(refs), bounds, 0, budget);
  result.cost_evals = builder.evals();
  return result;
}

}  // namespace splitray

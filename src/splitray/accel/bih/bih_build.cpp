// BIH construction: references partitioned in place by their box centres (so every
// primitive lands in exactly one child), clip planes from the children's extents, subtrees
// above a size built as parallel tasks and laid out deterministically (piece_tree.hpp).

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>

#include "splitray/accel/bih/bih.hpp"
#include "splitray/accel/bvh/object_split.hpp"
#include "splitray/accel/bvh/piece_tree.hpp"
#include "splitray/accel/robust_ray.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

constexpr std::size_t kTaskRefs = 4096;
constexpr std::size_t kHalveCoincident = 64;  // more coincident centres than this: halve the list
constexpr int kMaxBins = 256;

struct BihNodeTraits {
  static bool is_leaf(const BihNode& n) { return n.leaf(); }
  static std::uint32_t child(const BihNode& n) { return n.child(); }
  static void set_child(BihNode& n, std::uint32_t c) { n.bits = (c << 3) | (n.bits & 7u); }
  static void shift_leaf(BihNode& n, std::uint32_t by) { n.bits += by << 2; }
};
using BihPiece = Piece<BihNode>;

// A node under construction: its references [begin, end), their bounds, the region the
// traversal knows (the scene box cut by the ancestors' planes) and, for the global heuristic,
// the grid cell its candidates come from.
struct Task {
  std::size_t begin, end;
  RefBounds bounds;
  Aabb region, cell;
  int depth;
};

// A box with the interval [lo, hi] on one axis replaced.
Aabb with_interval(Aabb box, int axis, float lo, float hi) {
  box.lo[axis] = lo;
  box.hi[axis] = hi;
  return box;
}

class BihBuilder {
 public:
  BihBuilder(std::vector<BvhRef>& refs, const BihBuildOptions& options)
      : refs_(refs), options_(options) {}

  std::unique_ptr<BihPiece> build_piece(const Task& task) {
    auto piece = std::make_unique<BihPiece>();
    piece->nodes.resize(1);
    std::uint64_t evals = 0;
    build(*piece, 0, task, evals);
    evals_ += evals;
    return piece;
  }
  std::uint64_t evals() const { return evals_; }

 private:
  struct Split {
    int axis = -1;
    std::size_t n_left = 0;  // after partitioning
    RefBounds left, right;
    Aabb left_cell, right_cell;  // global heuristic
  };

  // Moves references with goes_left to the front; the bounds of both sides on the way.
  template <class GoesLeft>
  std::size_t partition(std::size_t begin, std::size_t end, const GoesLeft& goes_left,
                        RefBounds& left, RefBounds& right) {
    RefBoundsAccumulator l, r;
    std::size_t i = begin, j = end;
    for (;;) {
      while (i < j && goes_left(refs_[i])) l.add(refs_[i++]);
      while (i < j && !goes_left(refs_[j - 1])) r.add(refs_[--j]);
      if (i >= j) break;
      std::swap(refs_[i], refs_[j - 1]);
      l.add(refs_[i++]);
      r.add(refs_[--j]);
    }
    left = l.bounds();
    right = r.bounds();
    return i - begin;
  }

  // Splits at `plane` on `axis` by centre (< plane goes left); both sides must be non-empty.
  Split split_at(const Task& t, int axis, float plane) {
    Split s;
    s.axis = axis;
    s.n_left = partition(
        t.begin, t.end,
        [&](const BvhRef& r) { return (r.box.lo[axis] + r.box.hi[axis]) * 0.5f < plane; }, s.left,
        s.right);
    return s;
  }

  // A plane strictly inside the centres' interval, so that both sides get references.
  static float inner_plane(const Aabb& centers, int axis) {
    const float lo = centers.lo[axis], hi = centers.hi[axis];
    const float mid = (lo + hi) * 0.5f;
    return mid > lo ? mid : hi;
  }

  Split split_global(const Task& t) {
    Aabb cell = t.cell;
    const Aabb& c = t.bounds.centers;
    for (int attempt = 0; attempt < 512; ++attempt) {
      const int axis = cell.longest_axis();
      const float plane = cell.center()[axis];
      if (!(cell.hi[axis] > cell.lo[axis])) break;
      // A candidate with every centre on one side halves the cell without a node.
      if (c.lo[axis] >= plane) {
        if (cell.lo[axis] == plane) break;
        cell.lo[axis] = plane;
        continue;
      }
      if (c.hi[axis] < plane) {
        if (cell.hi[axis] == plane) break;
        cell.hi[axis] = plane;
        continue;
      }
      Split s = split_at(t, axis, plane);
      s.left_cell = with_interval(cell, axis, cell.lo[axis], plane);
      s.right_cell = with_interval(cell, axis, plane, cell.hi[axis]);
      return s;
    }
    // The grid cannot separate the centres any more (rounding): fall back to their middle.
    const int axis = c.longest_axis();
    Split s = split_at(t, axis, inner_plane(c, axis));
    s.left_cell = s.left.centers;
    s.right_cell = s.right.centers;
    return s;
  }

  Split split_middle(const Task& t) {
    const Aabb box = intersection(t.bounds.box, t.region);
    const int axis = box.longest_axis();
    const float plane = box.center()[axis];
    const Aabb& c = t.bounds.centers;
    if (c.lo[axis] < plane && c.hi[axis] >= plane) return split_at(t, axis, plane);
    const int caxis = c.longest_axis();
    return split_at(t, caxis, inner_plane(c, caxis));
  }

  Split split_median(const Task& t) {
    const int axis = t.bounds.centers.longest_axis();
    const std::size_t mid = t.begin + (t.end - t.begin) / 2;
    const auto center = [axis](const BvhRef& r) { return r.box.lo[axis] + r.box.hi[axis]; };
    std::nth_element(refs_.begin() + static_cast<std::ptrdiff_t>(t.begin),
                     refs_.begin() + static_cast<std::ptrdiff_t>(mid),
                     refs_.begin() + static_cast<std::ptrdiff_t>(t.end),
                     [&](const BvhRef& a, const BvhRef& b) {
                       return center(a) < center(b) || (center(a) == center(b) && a.prim < b.prim);
                     });
    Split s;
    s.axis = axis;
    s.n_left = mid - t.begin;
    for (std::size_t i = t.begin; i < t.end; ++i) (i < mid ? s.left : s.right).extend(refs_[i]);
    return s;
  }

  // Binned SAH over the regions the traversal will see: the node's region cut at the left
  // children's maximum and the right children's minimum. Returns axis -1 when a leaf is cheaper.
  Split split_sah(const Task& t, std::uint64_t& evals, bool may_stop) {
    struct Bin {  // raw: only the bins in use are initialised
      float max_hi, min_lo;
      std::uint32_t count;
    };
    const std::size_t n = t.end - t.begin;
    const CenterBins map(t.bounds.centers,
                         static_cast<int>(std::min<std::size_t>(
                             static_cast<std::size_t>(options_.bins), 2 * n + 4)));
    Bin bins[3][kMaxBins];
    for (auto& axis : bins)
      for (int i = 0; i < map.count; ++i)
        axis[i] = {-std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
                   0};
    for (std::size_t i = t.begin; i < t.end; ++i) {
      const BvhRef& r = refs_[i];
      for (int a = 0; a < 3; ++a) {
        Bin& b = bins[a][map.bin(r, a)];
        b.max_hi = std::max(b.max_hi, r.box.hi[a]);
        b.min_lo = std::min(b.min_lo, r.box.lo[a]);
        ++b.count;
      }
    }
    const float area = std::max(t.region.half_area(), std::numeric_limits<float>::min());
    float best_cost = std::numeric_limits<float>::infinity();
    int best_axis = -1, best_bin = 0;
    float right_min[kMaxBins];
    for (int a = 0; a < 3; ++a) {
      if (map.scale[a] == 0) continue;
      float acc = std::numeric_limits<float>::infinity();
      for (int i = map.count - 1; i > 0; --i) right_min[i] = acc = std::min(acc, bins[a][i].min_lo);
      float left_max = -std::numeric_limits<float>::infinity();
      std::size_t n_left = 0;
      for (int i = 0; i < map.count - 1; ++i) {
        left_max = std::max(left_max, bins[a][i].max_hi);
        n_left += bins[a][i].count;
        if (n_left == 0 || n_left == n) continue;
        ++evals;
        const float lh = std::min(left_max, t.region.hi[a]),
                    rl = std::max(right_min[i + 1], t.region.lo[a]);
        const float al = with_interval(t.region, a, t.region.lo[a], lh).half_area();
        const float ar = with_interval(t.region, a, rl, t.region.hi[a]).half_area();
        const float cost =
            options_.traversal_cost +
            options_.intersection_cost *
                (al * static_cast<float>(n_left) + ar * static_cast<float>(n - n_left)) / area;
        if (cost < best_cost) {
          best_cost = cost;
          best_axis = a;
          best_bin = i;
        }
      }
    }
    if (best_axis < 0) return {};
    if (may_stop && !(best_cost < options_.intersection_cost * static_cast<float>(n))) return {};
    Split s;
    s.axis = best_axis;
    s.n_left = partition(
        t.begin, t.end, [&](const BvhRef& r) { return map.bin(r, best_axis) <= best_bin; }, s.left,
        s.right);
    return s;
  }

  void make_leaf(BihPiece& piece, std::size_t slot, const Task& t) {
    piece.nodes[slot] = BihNode::make_leaf(static_cast<std::uint32_t>(t.begin),
                                           static_cast<std::uint32_t>(t.end - t.begin));
  }

  // The fifth case: a one-child node cutting the region down to the references' extent on
  // the axis where that removes the most area, when the saving for rays that miss the cut
  // region exceeds the cost of one more node. Returns -1 when it does not pay.
  int one_child_axis(const Task& t) const {
    const float area = t.region.half_area();
    if (!(area > 0)) return -1;
    const Aabb& box = t.bounds.box;
    int best = -1;
    float best_area = area;
    for (int a = 0; a < 3; ++a) {
      const float cut = with_interval(t.region, a, box.lo[a], box.hi[a]).half_area();
      if (cut < best_area) {
        best_area = cut;
        best = a;
      }
    }
    if (best < 0) return -1;
    // A rough cost of the subtree below: one traversal step per level, one leaf.
    const std::size_t n = t.end - t.begin;
    const float subtree = options_.traversal_cost * static_cast<float>(std::bit_width(n)) +
                          options_.intersection_cost *
                              static_cast<float>(std::min<std::size_t>(
                                  n, static_cast<std::size_t>(std::max(options_.leaf_size, 1))));
    return (1.0f - best_area / area) * subtree > options_.traversal_cost ? best : -1;
  }

  void build(BihPiece& piece, std::size_t slot, const Task& t, std::uint64_t& evals) {
    const std::size_t n = t.end - t.begin;
    if (n <= static_cast<std::size_t>(options_.leaf_size) || t.depth >= options_.max_depth)
      return make_leaf(piece, slot, t);
    const Aabb& centers = t.bounds.centers;
    const bool coincident = !(centers.hi.x > centers.lo.x || centers.hi.y > centers.lo.y ||
                              centers.hi.z > centers.lo.z);
    if (coincident && n <= kHalveCoincident) return make_leaf(piece, slot, t);

    if (options_.one_child_nodes && t.depth + 1 < options_.max_depth) {
      const int axis = one_child_axis(t);
      if (axis >= 0) {
        const float lo = t.bounds.box.lo[axis], hi = t.bounds.box.hi[axis];
        Task child = t;
        child.region = with_interval(t.region, axis, lo, hi);
        child.depth = t.depth + 1;
        if (slot == 0 && piece.nodes.size() == 1 && n >= kTaskRefs) {  // keep big subtrees parallel
          piece.nodes[0] = BihNode::make_one_child(axis, lo, hi);
          piece.kids[0] = build_piece(child);
          return;
        }
        const auto c = static_cast<std::uint32_t>(piece.nodes.size());
        piece.nodes.resize(c + 1);
        piece.nodes[slot] = BihNode::make_one_child(axis, lo, hi, c);
        return build(piece, c, child, evals);
      }
    }

    Split s;
    if (coincident) {  // halve the list: both children overlap, but the recursion ends
      s.axis = 0;
      s.n_left = n / 2;
      for (std::size_t i = t.begin; i < t.end; ++i)
        (i < t.begin + s.n_left ? s.left : s.right).extend(refs_[i]);
    } else {
      switch (options_.heuristic) {
        case BihHeuristic::global:
          s = split_global(t);
          break;
        case BihHeuristic::median:
          s = split_median(t);
          break;
        case BihHeuristic::middle:
          s = split_middle(t);
          break;
        case BihHeuristic::sah:
          s = split_sah(t, evals, n <= static_cast<std::size_t>(options_.max_leaf_sah));
          if (s.axis < 0) return make_leaf(piece, slot, t);
          break;
      }
    }
    const int axis = s.axis;
    const float left_max = s.left.box.hi[axis], right_min = s.right.box.lo[axis];
    const std::size_t mid = t.begin + s.n_left;
    Task left{t.begin, mid, s.left, t.region, s.left_cell, t.depth + 1};
    Task right{mid, t.end, s.right, t.region, s.right_cell, t.depth + 1};
    left.region.hi[axis] = std::min(t.region.hi[axis], left_max);
    right.region.lo[axis] = std::max(t.region.lo[axis], right_min);

    if (slot == 0 && piece.nodes.size() == 1 && n >= kTaskRefs) {
      piece.nodes[0] = BihNode::make_interior(axis, left_max, right_min);
      parallel_invoke([&] { piece.kids[0] = build_piece(left); },
                      [&] { piece.kids[1] = build_piece(right); });
      return;
    }
    const auto pair = static_cast<std::uint32_t>(piece.nodes.size());
    piece.nodes.resize(pair + 2);
    piece.nodes[slot] = BihNode::make_interior(axis, left_max, right_min, pair);
    build(piece, pair, left, evals);
    build(piece, pair + 1, right, evals);
  }

  std::vector<BvhRef>& refs_;
  const BihBuildOptions& options_;
  std::atomic<std::uint64_t> evals_{0};
};

}  // namespace

namespace {

struct NamedHeuristic {
  const char* name;
  BihHeuristic heuristic;
};
constexpr NamedHeuristic kHeuristics[] = {{"global", BihHeuristic::global},
                                          {"median", BihHeuristic::median},
                                          {"middle", BihHeuristic::middle},
                                          {"sah", BihHeuristic::sah}};

}  // namespace

std::vector<std::string> bih_builder_names() {
  std::vector<std::string> names;
  for (const NamedHeuristic& h : kHeuristics) names.emplace_back(h.name);
  return names;
}

BihHeuristic parse_bih_heuristic(const std::string& name) {
  if (name.empty()) return kHeuristics[0].heuristic;
  std::string known;
  for (const NamedHeuristic& h : kHeuristics) {
    if (name == h.name) return h.heuristic;
    known += std::string(known.empty() ? "" : ", ") + h.name;
  }
  throw Error("--builder", "'" + name + "' is not a BIH builder (known: " + known + ")");
}

BihBuildOptions BihBuildOptions::from(const BuildConfig& config, BihHeuristic heuristic) {
  BihBuildOptions o;
  o.heuristic = heuristic;
  const SahConstants k = config.sah(kSharedSah);  // the BIH's defaults
  o.traversal_cost = k.traversal;
  o.intersection_cost = k.intersection;
  o.leaf_size = std::max(config.max_leaf_prims, 1);
  o.bins = std::clamp(config.bins, 4, kMaxBins);
  o.max_depth = config.max_depth > 0 ? std::min(config.max_depth, 64) : 64;
  return o;
}

Bih Bih::build(std::span<const Triangle> triangles, const BihBuildOptions& options) {
  Bih bih;
  if (triangles.empty()) return bih;
  std::vector<BvhRef> refs = make_prim_refs(triangles);
  const RefBounds bounds = ref_bounds(refs);
  BihBuilder builder(refs, options);
  const auto root = builder.build_piece({0, refs.size(), bounds, bounds.box, bounds.box, 0});
  flatten_pieces<BihNodeTraits>(*root, bih.nodes_, bih.ids_);
  bih.ids_.resize(refs.size());
  bih.tris_.resize(refs.size());
  parallel_chunks(refs.size(), 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      bih.ids_[i] = refs[i].prim;
      bih.tris_[i] = triangles[refs[i].prim];
    }
  });
  bih.scene_ = bounds.box;
  bih.magnitude_ = coordinate_magnitude(bounds.box);
  bih.cost_evals_ = builder.evals();
  return bih;
}

}  // namespace splitray

// Exact SAH kd-tree in O(N log N) (Wald & Havran 2006, "On building fast kd-trees for ray
// tracing, and on doing that in O(N log N)"): the start/end/planar events of every triangle
// are sorted once per axis; each node sweeps its sorted events to find the cheapest plane,
// classifies its triangles below/above/both and splits the event lists in linear time.
// Triangles that straddle the plane are clipped to each child cell (perfect splits) and only
// their new events are sorted and merged in. Subtrees build as TBB tasks; every decision
// depends on the data only, so the tree is the same for any thread count.

#include <algorithm>
#include <array>
#include <atomic>
#include <limits>

#include "splitray/accel/kd/kd_build.hpp"
#include "splitray/accel/kd/kd_emit.hpp"
#include "splitray/accel/kd/kd_sah.hpp"
#include "splitray/accel/triangle_clip.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

// Event types in the sweep order at one position: triangles ending there leave the above side
// before the plane is evaluated, triangles starting there join the below side after it.
enum : std::uint32_t { kEnd = 0, kPlanar = 1, kStart = 2 };
constexpr std::uint32_t kIndexBits = 30;
constexpr std::uint32_t kIndexMask = (1u << kIndexBits) - 1;

struct Event {
  float pos;
  std::uint32_t key;  // type << 30 | index of the triangle in its node's list

  std::uint32_t type() const { return key >> kIndexBits; }
  std::uint32_t tri() const { return key & kIndexMask; }
  // Total order (position, type, triangle), so sorting is deterministic.
  friend bool operator<(const Event& a, const Event& b) {
    return a.pos < b.pos || (a.pos == b.pos && a.key < b.key);
  }
};

using AxisEvents = std::array<std::vector<Event>, 3>;

// Leaves elements uninitialised on resize(): arrays that are written right after.
template <typename T>
struct UninitAllocator : std::allocator<T> {
  template <typename U>
  struct rebind {
    using other = UninitAllocator<U>;
  };
  UninitAllocator() = default;
  template <typename U>
  UninitAllocator(const UninitAllocator<U>&) noexcept {}
  template <typename U>
  void construct(U* p) noexcept {
    ::new (static_cast<void*>(p)) U;
  }
  template <typename U, typename... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

// One node's work: its cell, its triangles and their events, the three axes' sorted lists
// one after another in one array (fewer allocations per node).
struct Node {
  Aabb box;
  std::vector<std::uint32_t> tris;  // triangle ids; events refer to positions in this list
  std::vector<Event, UninitAllocator<Event>> events;
  std::array<std::size_t, 4> axis_begin{};  // events of axis a: [axis_begin[a], axis_begin[a+1])

  std::span<const Event> axis(int a) const {
    return {events.data() + axis_begin[a], events.data() + axis_begin[a + 1]};
  }
};

void add_events(const Aabb& b, std::uint32_t index, AxisEvents& out) {
  for (int axis = 0; axis < 3; ++axis) {
    if (b.lo[axis] == b.hi[axis]) {
      out[axis].push_back({b.lo[axis], (kPlanar << kIndexBits) | index});
    } else {
      out[axis].push_back({b.lo[axis], (kStart << kIndexBits) | index});
      out[axis].push_back({b.hi[axis], (kEnd << kIndexBits) | index});
    }
  }
}

struct Split {
  double cost = std::numeric_limits<double>::infinity();
  int axis = -1;
  float pos = 0;
  bool planar_below = true;  // where the triangles lying in the plane go
};

enum Side : std::uint8_t { kBoth = 0, kBelow = 1, kAbove = 2 };

class SahBuilder {
 public:
  SahBuilder(std::span<const Triangle> triangles, const BuildConfig& config)
      : triangles_(triangles),
        sah_(config),
        max_depth_(kd_max_depth(config, triangles.size())),
        max_leaf_prims_(static_cast<std::size_t>(std::max(config.max_leaf_prims, 0))) {}

  // A subtree of at least kParallelPrims triangles: its children build as tasks, each into a
  // part of its own; smaller subtrees are written into one chunk, depth first (kd_emit.hpp).
  std::unique_ptr<KdPartial> build(Node node, int depth) {
    auto part = std::make_unique<KdPartial>();
    if (node.tris.size() < kParallelPrims) {
      build_chunk(std::move(node), depth, part->chunk);
      return part;
    }
    const Split split = choose(node, depth);
    if (split.axis < 0) {
      add_leaf(node, part->chunk);
      return part;
    }
    Node below, above;
    partition(node, split, below, above);
    node = Node{};  // free the parent's lists before descending
    part->axis = split.axis;
    part->split = split.pos;
    parallel_invoke([&] { part->below = build(std::move(below), depth + 1); },
                    [&] { part->above = build(std::move(above), depth + 1); });
    return part;
  }

  std::uint64_t cost_evals() const { return cost_evals_.load(); }

 private:
  static constexpr std::size_t kParallelPrims = 2048;        // smaller subtrees: one task
  static constexpr std::size_t kParallelSweepPrims = 32768;  // sweep the three axes at once

  void build_chunk(Node node, int depth, KdChunk& out) {
    const Split split = choose(node, depth);
    if (split.axis < 0) {
      add_leaf(node, out);
      return;
    }
    Node below, above;
    partition(node, split, below, above);
    node = Node{};
    const std::size_t index = out.open_interior();
    build_chunk(std::move(below), depth + 1, out);
    out.set_interior(index, split.axis, split.pos);
    build_chunk(std::move(above), depth + 1, out);
  }

  // The split to make, or axis -1 for a leaf.
  Split choose(const Node& node, int depth) {
    const std::size_t n = node.tris.size();
    if (n <= max_leaf_prims_ || depth >= max_depth_) return {};
    Split split = find_split(node);
    if (!(split.cost < sah_.leaf(n))) split.axis = -1;
    return split;
  }

  static void add_leaf(Node& node, KdChunk& out) {
    std::sort(node.tris.begin(), node.tris.end());
    out.add_leaf(node.tris);
  }

  Split find_split(const Node& node) {
    std::array<Split, 3> best;
    std::array<std::uint64_t, 3> evals{};
    const auto sweep = [&](int axis) { best[axis] = sweep_axis(node, axis, evals[axis]); };
    if (node.tris.size() >= kParallelSweepPrims) {
      parallel_invoke([&] { sweep(0); }, [&] { sweep(1); }, [&] { sweep(2); });
    } else {
      for (int axis = 0; axis < 3; ++axis) sweep(axis);
    }
    cost_evals_.fetch_add(evals[0] + evals[1] + evals[2], std::memory_order_relaxed);
    // The first minimum in the order axis, position, side, whatever ran where.
    Split result = best[0];
    for (int axis = 1; axis < 3; ++axis)
      if (best[axis].cost < result.cost) result = best[axis];
    return result;
  }

  // The sweep over one axis: for every distinct event position, the counts below/in/above the
  // plane are known from the events before it; planar triangles are tried on both sides.
  Split sweep_axis(const Node& node, int axis, std::uint64_t& evals) const {
    const KdAxisCost cost(sah_, node.box, axis);
    const float lo = node.box.lo[axis], hi = node.box.hi[axis];
    const std::span<const Event> events = node.axis(axis);
    const Event* e = events.data();
    const Event* const end = e + events.size();
    std::size_t n_below = 0, n_above = node.tris.size();
    Split best;
    while (e != end) {
      const float pos = e->pos;
      std::size_t ends = 0, planars = 0, starts = 0;
      for (; e != end && e->pos == pos && e->type() == kEnd; ++e) ++ends;
      for (; e != end && e->pos == pos && e->type() == kPlanar; ++e) ++planars;
      for (; e != end && e->pos == pos && e->type() == kStart; ++e) ++starts;
      n_above -= planars + ends;
      if (pos > lo && pos < hi) {
        const double cost_below = cost(pos, n_below + planars, n_above);
        ++evals;
        if (cost_below < best.cost) best = {cost_below, axis, pos, true};
        if (planars > 0) {
          const double cost_above = cost(pos, n_below, n_above + planars);
          ++evals;
          if (cost_above < best.cost) best = {cost_above, axis, pos, false};
        }
      } else if (planars > 0 && lo < hi) {
        // A plane on the cell's boundary cuts off the triangles lying in that face into a flat
        // cell of their own: the rest of the cell loses them, or is cut off as empty space (a
        // floor under empty space, a wall of a room). Both children are smaller than the cell
        // (one is flat, the other has fewer triangles), so such splits always progress.
        const bool below = pos == lo;
        const double c =
            below ? cost(pos, n_below + planars, n_above) : cost(pos, n_below, n_above + planars);
        ++evals;
        if (c < best.cost) best = {c, axis, pos, below};
      }
      n_below += starts + planars;
    }
    return best;
  }

  // Per-thread buffers of partition(), which never waits for other tasks while using them.
  struct Scratch {
    std::vector<std::uint8_t> side;
    std::vector<std::uint32_t> below_index, above_index, straddling;
    AxisEvents fresh_below, fresh_above;
  };

  void partition(const Node& node, const Split& split, Node& below, Node& above) const {
    thread_local Scratch scratch;
    const std::size_t n = node.tris.size();
    std::vector<std::uint8_t>& side = scratch.side;
    side.assign(n, kBoth);
    for (const Event& e : node.axis(split.axis)) {
      const std::uint32_t type = e.type();
      if (type == kEnd && e.pos <= split.pos) {
        side[e.tri()] = kBelow;
      } else if (type == kStart && e.pos >= split.pos) {
        side[e.tri()] = kAbove;
      } else if (type == kPlanar) {
        const bool go_below = e.pos < split.pos || (e.pos == split.pos && split.planar_below);
        side[e.tri()] = go_below ? kBelow : kAbove;
      }
    }

    below.box = above.box = node.box;
    below.box.hi[split.axis] = split.pos;
    above.box.lo[split.axis] = split.pos;

    // New positions in the children's lists, in the parent's order.
    std::vector<std::uint32_t>& below_index = scratch.below_index;
    std::vector<std::uint32_t>& above_index = scratch.above_index;
    std::vector<std::uint32_t>& straddling = scratch.straddling;
    below_index.resize(n);
    above_index.resize(n);
    straddling.clear();
    std::size_t n_below = 0, n_above = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (side[i] != kAbove) below_index[i] = static_cast<std::uint32_t>(n_below++);
      if (side[i] != kBelow) above_index[i] = static_cast<std::uint32_t>(n_above++);
      if (side[i] == kBoth) straddling.push_back(static_cast<std::uint32_t>(i));
    }
    below.tris.resize(n_below);
    above.tris.resize(n_above);
    for (std::size_t i = 0; i < n; ++i) {
      if (side[i] != kAbove) below.tris[below_index[i]] = node.tris[i];
      if (side[i] != kBelow) above.tris[above_index[i]] = node.tris[i];
    }

    // Straddling triangles get new events from their part in each child, sorted per axis.
    for (int axis = 0; axis < 3; ++axis) {
      scratch.fresh_below[axis].clear();
      scratch.fresh_above[axis].clear();
    }
    for (const std::uint32_t i : straddling) {
      Aabb b, a;
      clip_triangle_split(triangles_[node.tris[i]], node.box, split.axis, split.pos, b, a);
      add_events(b, below_index[i], scratch.fresh_below);
      add_events(a, above_index[i], scratch.fresh_above);
    }
    for (int axis = 0; axis < 3; ++axis) {
      std::sort(scratch.fresh_below[axis].begin(), scratch.fresh_below[axis].end());
      std::sort(scratch.fresh_above[axis].begin(), scratch.fresh_above[axis].end());
    }
    // Events of one-sided triangles stay valid and sorted: filter them and merge the new ones
    // in, in one linear pass per child and axis.
    fill_child(node, side, kBelow, below_index, scratch.fresh_below, below);
    fill_child(node, side, kAbove, above_index, scratch.fresh_above, above);
  }

  // Sized for the most the child can get (its share of the parent's events plus the new
  // ones) and trimmed after, so one pass suffices; the slack lives only until the child is
  // split in turn.
  static void fill_child(const Node& node, const std::vector<std::uint8_t>& side, Side keep,
                         const std::vector<std::uint32_t>& new_index, const AxisEvents& fresh,
                         Node& child) {
    child.events.resize(node.events.size() + fresh[0].size() + fresh[1].size() + fresh[2].size());
    Event* const first = child.events.data();
    Event* out = first;
    for (int axis = 0; axis < 3; ++axis) {
      child.axis_begin[axis] = static_cast<std::size_t>(out - first);
      const Event* add = fresh[axis].data();
      const Event* const add_end = add + fresh[axis].size();
      for (const Event& e : node.axis(axis)) {
        if (side[e.tri()] != keep) continue;
        const Event moved{e.pos, (e.key & ~kIndexMask) | new_index[e.tri()]};
        while (add != add_end && *add < moved) *out++ = *add++;
        *out++ = moved;
      }
      while (add != add_end) *out++ = *add++;
    }
    child.axis_begin[3] = static_cast<std::size_t>(out - first);
    child.events.resize(child.axis_begin[3]);
  }

  std::span<const Triangle> triangles_;
  KdSplitCost sah_;
  int max_depth_;
  std::size_t max_leaf_prims_;
  std::atomic<std::uint64_t> cost_evals_{0};
};

}  // namespace

KdBuildResult build_kd_sah(std::span<const Triangle> triangles, const Aabb& bounds,
                           const BuildConfig& config) {
  if (triangles.size() > kIndexMask)
    throw Error("--builder sah", "too many triangles (" + std::to_string(triangles.size()) + ")");
  Node root;
  root.box = bounds;
  root.tris.reserve(triangles.size());
  AxisEvents events;
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    Aabb b = triangles[i].bounds();
    if (!(bounds.contains(b.lo) && bounds.contains(b.hi)))
      b = clip_triangle_bounds(triangles[i], bounds);
    if (b.empty()) continue;  // outside the root cell
    const auto index = static_cast<std::uint32_t>(root.tris.size());
    root.tris.push_back(static_cast<std::uint32_t>(i));
    add_events(b, index, events);
  }
  parallel_invoke([&] { std::sort(events[0].begin(), events[0].end()); },
                  [&] { std::sort(events[1].begin(), events[1].end()); },
                  [&] { std::sort(events[2].begin(), events[2].end()); });
  for (int axis = 0; axis < 3; ++axis) {
    root.axis_begin[axis] = root.events.size();
    root.events.insert(root.events.end(), events[axis].begin(), events[axis].end());
    events[axis] = {};
  }
  root.axis_begin[3] = root.events.size();

  SahBuilder builder(triangles, config);
  KdBuildResult result;
  const std::unique_ptr<KdPartial> top = builder.build(std::move(root), 0);
  result.tree = assemble_kd(*top, bounds);
  result.cost_evals = builder.cost_evals();
  return result;
}

}  // namespace splitray

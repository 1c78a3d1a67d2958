// Coherent kd rebuilds (coherent_builder.hpp). The previous frame's tree is kept as a shape:
// per node its axis, its plane as a fraction of the cell, the references that reached it and
// the subtree's cost ratio when it was last built from scratch. A frame walks the shape top
// down with the frame's triangles:
//  - a node's plane sits at the same fraction of its new cell (the cell moves and scales with
//    the content); nodes of at least config_coherent_.search_prims references re-search their plane
//    locally, in the bracket paper 000's filters predict (Algorithm 1, search_predicted), and feed
//    the filters the result;
//  - the references are counted and partitioned at the plane in one pass (straddlers clipped
//    to each child, as every builder does), with no event lists and no full search;
//  - a leaf that gained references, a plane that no longer pays (split cost >= leaf cost) and
//    a subtree whose cost ratio grew by more than config_coherent_.subtree_tolerance since it was
//    built are rebuilt from scratch by golden (build_kd_golden_refs), whose planes are then adopted
//    exactly: the tree's quality cannot decay over a sequence, and a sudden jump rebuilds
//    what it broke (at the root: the whole tree).
// Large subtrees are built as parallel tasks; every decision depends only on the data and
// the filters' state, so the tree is the same for any thread count.
#include "splitray/accel/kd/coherent_builder.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>

#include "splitray/accel/kd/golden_build.hpp"
#include "splitray/accel/kd/kd_emit.hpp"
#include "splitray/accel/kd/kd_sah.hpp"
#include "splitray/accel/kd/predicted_builder.hpp"
#include "splitray/accel/triangle_clip.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"

namespace splitray {

namespace {

constexpr std::size_t kTaskPrims = 4096;      // subtrees this large are built as parallel tasks
constexpr double kUnpredictedBracket = 0.05;  // half width (cell fractions) without a forecast

// A leaf of the shape is rebuilt once it holds this many more references than when made.
std::size_t grown_leaf(std::size_t prims) { return prims + std::max<std::size_t>(2, prims / 4); }

struct ShapeNode {
  std::int8_t axis = -1;  // -1: leaf
  bool planar_below = true;
  float fraction = 0;       // the plane as a fraction of the cell on `axis`
  float position = 0;       // the plane's position (adopted exactly from a fresh build)
  std::uint32_t above = 0;  // index of the above child, from the start of its shape
  std::uint32_t prims = 0;  // references that reached the node
  float built_ratio = 0;    // subtree cost / leaf cost when last built from scratch
  float split_ratio = 0;    // the plane's own cost / leaf cost then (children as leaves)
  // The triangle bound the plane lies on (2 id + 0 for its lower, 1 for its upper bound on
  // `axis`), kNoAnchor when none: SAH planes hug triangles, and following the triangle keeps
  // the plane where it separated them as the mesh deforms.
  std::uint32_t anchor = kNoAnchor;
  static constexpr std::uint32_t kNoAnchor = ~0u;
};
using Shape = std::vector<ShapeNode>;

// Where a node's shape comes from: the previous frame's (planes by fraction) or a fresh
// golden build of this frame (planes exactly).
struct ShapeRef {
  const ShapeNode* nodes;
  std::uint32_t index;
  bool fresh;
  const ShapeNode& node() const { return nodes[index]; }
  ShapeRef below() const { return {nodes, index + 1, fresh}; }
  ShapeRef above() const { return {nodes, node().above, fresh}; }
};

// Node counts of a subtree by origin, and its cost (relative to its cell's area).
struct Built {
  double cost = 0;
  std::size_t reused = 0, reoptimised = 0, rebuilt = 0, rebuilds = 0;
  void add(const Built& b) {
    reused += b.reused, reoptimised += b.reoptimised, rebuilt += b.rebuilt;
    rebuilds += b.rebuilds;
  }
};

// A finished subtree: an interior node with two parts (large subtrees, built as tasks) or a
// chunk of nodes with their shape (relative indices).
struct Part {
  int axis = -1;  // -1: `chunk` and `shape` hold the subtree
  float split = 0;
  ShapeNode node;
  std::unique_ptr<Part> below, above;
  KdChunk chunk;
  Shape shape;
};

// The shape of a chunk of golden's nodes (relative indices), planes only.
Shape shape_of(std::span<const KdNode> nodes) {
  Shape shape(nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (nodes[i].is_leaf()) continue;
    shape[i].axis = static_cast<std::int8_t>(nodes[i].axis());
    shape[i].position = nodes[i].split;
    shape[i].above = nodes[i].above();
  }
  return shape;
}

void append_shape(Part& part, Shape& out) {
  if (part.axis < 0) {
    const auto base = static_cast<std::uint32_t>(out.size());
    for (ShapeNode n : part.shape) {
      if (n.axis >= 0) n.above += base;
      out.push_back(n);
    }
    return;
  }
  const std::size_t index = out.size();
  out.push_back(part.node);
  append_shape(*part.below, out);
  out[index].above = static_cast<std::uint32_t>(out.size());
  append_shape(*part.above, out);
}

std::unique_ptr<KdPartial> to_partial(Part& part) {
  auto p = std::make_unique<KdPartial>();
  p->axis = part.axis;
  p->split = part.split;
  if (part.axis < 0) {
    p->chunk = std::move(part.chunk);
    return p;
  }
  p->below = to_partial(*part.below);
  p->above = to_partial(*part.above);
  return p;
}

struct Counters {
  double walk_ms = 0;  // the walk's own CPU time, searches and rebuilds included
  double search_ms = 0, rebuild_ms = 0;
  std::uint64_t evals = 0;
  std::vector<SplitObservation> observations;
};

// Per-thread arenas (kept from frame to frame) and the frame's counters.
struct Locals {
  BumpArena refs, scratch;
  Counters counters;
};
using ThreadLocals = ThreadLocal<Locals>;

class CoherentFrame {
 public:
  CoherentFrame(std::span<const Triangle> triangles, const BuildConfig& config,
                const CoherentConfig& coherent, const SplitPredictor& predictor,
                ThreadLocals& locals)
      : triangles_(triangles),
        config_(config),
        config_coherent_(coherent),
        predictor_(predictor),
        locals_(locals),
        cost_(config),
        max_depth_(kd_max_depth(config, triangles.size())),
        max_leaf_(static_cast<std::size_t>(std::max(config.max_leaf_prims, 0))) {}

  // The subtree of `refs` in `cell` following `shape`, as parallel tasks while large.
  std::unique_ptr<Part> task(ShapeRef shape, std::span<const PrimRef> refs, const Aabb& cell,
                             const Aabb& content, int depth, std::uint64_t path,
                             Built& built) const {
    auto part = std::make_unique<Part>();
    Locals& local = locals_.local();
    Timer timer;
    if (refs.size() < kTaskPrims) {
      built = node(shape, refs, cell, content, depth, path, part->chunk, part->shape, local);
      local.counters.walk_ms += timer.ms();
      return part;
    }
    Plan plan = plan_node(shape, refs, cell, content, depth, path, local);
    // The children's references live on the heap: tasks may run on other threads.
    const auto below_refs = std::make_unique_for_overwrite<PrimRef[]>(refs.size());
    const auto above_refs = std::make_unique_for_overwrite<PrimRef[]>(refs.size());
    Children c;
    if (plan.kind == Plan::cut)
      c = split_refs(plan, shape, refs, cell, below_refs.get(), above_refs.get());
    if (plan.kind != Plan::cut) {
      built = finish(plan, shape, refs, cell, content, depth, part->chunk, part->shape, local);
      local.counters.walk_ms += timer.ms();
      return part;
    }
    local.counters.walk_ms += timer.ms();
    const std::span<const PrimRef> below(below_refs.get(), plan.split.n_below);
    const std::span<const PrimRef> above(above_refs.get(), plan.split.n_above);
    Built b, a;
    parallel_invoke(
        [&] {
          part->below = task(shape.below(), below, c.below_cell, c.below_content, depth + 1,
                             path_child(path, false), b);
        },
        [&] {
          part->above = task(shape.above(), above, c.above_cell, c.above_content, depth + 1,
                             path_child(path, true), a);
        });
    built = combine(plan, shape, cell, b, a);
    if (drifted(shape, built, refs.size())) {
      part = std::make_unique<Part>();
      Locals& after = locals_.local();  // the children may have run on other threads
      timer.reset();
      built = rebuild(refs, cell, content, depth, part->chunk, part->shape, after);
      after.counters.walk_ms += timer.ms();
      return part;
    }
    part->axis = plan.split.axis;
    part->split = plan.split.position;
    part->node = shape_node(plan, shape, refs.size(), content, built);
    return part;
  }

  Counters counters() const {
    Counters all;
    for (const Locals& l : locals_) {
      all.walk_ms += l.counters.walk_ms;
      all.search_ms += l.counters.search_ms;
      all.rebuild_ms += l.counters.rebuild_ms;
      all.evals += l.counters.evals;
      all.observations.insert(all.observations.end(), l.counters.observations.begin(),
                              l.counters.observations.end());
    }
    return all;
  }

 private:
  struct Plan {
    enum Kind { leaf, rebuild, cut } kind = leaf;
    BinnedSplit split;
    bool searched = false;
    bool planar_known = false;  // the search decided where in-plane primitives go
    float split_ratio = 0;
    std::uint32_t anchor = ShapeNode::kNoAnchor;
  };

  // A node of a sequential subtree, appended to `out` and `shape`.
  Built node(ShapeRef shape, std::span<const PrimRef> refs, const Aabb& cell, const Aabb& content,
             int depth, std::uint64_t path, KdChunk& out, Shape& shape_out, Locals& local) const {
    Plan plan = plan_node(shape, refs, cell, content, depth, path, local);
    const BumpArena::Mark mark = local.refs.mark();
    PrimRef* below_refs = nullptr;
    PrimRef* above_refs = nullptr;
    Children c;
    if (plan.kind == Plan::cut) {
      below_refs = local.refs.allocate<PrimRef>(refs.size());
      above_refs = local.refs.allocate<PrimRef>(refs.size());
      c = split_refs(plan, shape, refs, cell, below_refs, above_refs);
    }
    if (plan.kind != Plan::cut) {
      local.refs.release(mark);
      return finish(plan, shape, refs, cell, content, depth, out, shape_out, local);
    }
    const std::span<const PrimRef> below(below_refs, plan.split.n_below);
    const std::span<const PrimRef> above(above_refs, plan.split.n_above);
    const std::size_t first_node = out.nodes.size(), first_prim = out.prims.size();
    const std::size_t first_shape = shape_out.size();
    const std::size_t index = out.open_interior();
    shape_out.emplace_back();
    const Built b = node(shape.below(), below, c.below_cell, c.below_content, depth + 1,
                         path_child(path, false), out, shape_out, local);
    out.set_interior(index, plan.split.axis, plan.split.position);
    shape_out[first_shape].above = static_cast<std::uint32_t>(shape_out.size());
    const Built a = node(shape.above(), above, c.above_cell, c.above_content, depth + 1,
                         path_child(path, true), out, shape_out, local);
    local.refs.release(mark);
    Built built = combine(plan, shape, cell, b, a);
    if (drifted(shape, built, refs.size())) {
      out.nodes.resize(first_node);
      out.prims.resize(first_prim);
      shape_out.resize(first_shape);
      return rebuild(refs, cell, content, depth, out, shape_out, local);
    }
    const std::uint32_t above_index = shape_out[first_shape].above;
    shape_out[first_shape] = shape_node(plan, shape, refs.size(), content, built);
    shape_out[first_shape].above = above_index;
    return built;
  }

  // Leaf and rebuild plans.
  Built finish(const Plan& plan, ShapeRef shape, std::span<const PrimRef> refs, const Aabb& cell,
               const Aabb& content, int depth, KdChunk& out, Shape& shape_out,
               Locals& local) const {
    if (plan.kind == Plan::rebuild)
      return rebuild(refs, cell, content, depth, out, shape_out, local);
    out.nodes.push_back(KdNode::leaf(static_cast<std::uint32_t>(out.prims.size()),
                                     static_cast<std::uint32_t>(refs.size())));
    for (const PrimRef& r : refs) out.prims.push_back(r.id);
    ShapeNode leaf;
    leaf.prims = static_cast<std::uint32_t>(refs.size());
    // A leaf kept from the previous frame remembers its size when made, so that growth is
    // measured against that rather than creeping up frame by frame.
    leaf.built_ratio = 1;
    if (!shape.fresh && shape.node().axis < 0) leaf.prims = shape.node().prims;
    shape_out.push_back(leaf);
    Built built;
    built.cost = cost_.leaf(refs.size());
    (shape.fresh ? built.rebuilt : built.reused) = 1;
    return built;
  }

  // Golden's subtree of `refs`, its planes then adopted exactly (so that its shape records
  // counts and costs).
  Built rebuild(std::span<const PrimRef> refs, const Aabb& cell, const Aabb& content, int depth,
                KdChunk& out, Shape& shape_out, Locals& local) const {
    const Timer timer;
    KdChunk fresh;
    local.counters.evals +=
        build_kd_golden_refs(refs, triangles_, cell, depth, triangles_.size(), config_, fresh);
    const Shape shape = shape_of(fresh.nodes);
    Built built =
        node({shape.data(), 0, true}, refs, cell, content, depth, 0, out, shape_out, local);
    local.counters.rebuild_ms += timer.ms();  // fresh shapes never search nor rebuild
    built.rebuilds += 1;
    return built;
  }

  Plan plan_node(ShapeRef shape, std::span<const PrimRef> refs, const Aabb& cell,
                 const Aabb& content, int depth, std::uint64_t path, Locals& local) const {
    const std::size_t n = refs.size();
    Plan plan;
    if (n <= max_leaf_ || depth >= max_depth_ || !(cell.half_area() > 0)) return plan;
    const ShapeNode& s = shape.node();
    if (s.axis < 0) {
      if (!shape.fresh && n > grown_leaf(s.prims)) plan.kind = Plan::rebuild;
      return plan;
    }
    const int axis = s.axis;
    const float lo = cell.lo[axis], hi = cell.hi[axis];
    if (!(lo < hi)) {
      plan.kind = shape.fresh ? Plan::leaf : Plan::rebuild;
      return plan;
    }
    BinnedSplit& split = plan.split;
    split.axis = axis;
    if (shape.fresh) {
      split.position = s.position;
    } else if (const float v = anchored(s); lo <= v && v <= hi) {
      split.position = v;
    } else {
      // Without its triangle, a kept plane sits at the same fraction of the node's content
      // (so that cuts of empty space stay at the content's faces), inside the cell.
      const double c_lo = content.lo[axis];
      const double c_extent = static_cast<double>(content.hi[axis]) - c_lo;
      split.position = std::clamp(static_cast<float>(c_lo + s.fraction * c_extent), lo, hi);
    }
    if (!shape.fresh && n >= config_coherent_.search_prims) {
      const GoldenSearchResult r = search(s, split.position, refs, cell, depth, path, local);
      if (r.best.valid()) {
        split.position = r.best.position;
        split.planar_below = r.best.planar_below;
        plan.planar_known = true;
        plan.searched = true;
      }
    }
    plan.kind = Plan::cut;
    return plan;
  }

  // The plane of a large node searched around its forecast (paper 000, Algorithm 1), or
  // around the previous frame's plane when the filters have none; the result is observed.
  GoldenSearchResult search(const ShapeNode& s, float kept, std::span<const PrimRef> refs,
                            const Aabb& cell, int depth, std::uint64_t path, Locals& local) const {
    const Timer timer;
    std::optional<SplitPrediction> forecast = predictor_.predict(path, depth);
    const bool forecast_used = forecast && forecast->axis == s.axis;
    SplitPrediction p;
    if (forecast_used) {
      p = *forecast;
    } else {
      p.axis = s.axis;
      p.fraction = (kept - static_cast<double>(cell.lo[s.axis])) /
                   (static_cast<double>(cell.hi[s.axis]) - cell.lo[s.axis]);
      p.half_width = kUnpredictedBracket;
    }
    p.max_cost_ratio = std::numeric_limits<double>::infinity();
    const double leaf = cost_.leaf(refs.size());
    const auto bracket = [&](int axis, float lo, float hi, float start) {
      return search_bracket_refs(refs, cell, axis, cost_, lo, hi, start, local.scratch);
    };
    PredictedSearch found = search_predicted(p, cell, leaf, bracket);
    GoldenSearchResult r = found.result;
    if (!found.accepted) {  // the minimum left the bracket: the whole axis, from the forecast
      const int a = s.axis;
      const float start = static_cast<float>(cell.lo[a] + p.fraction * (cell.hi[a] - cell.lo[a]));
      const GoldenSearchResult wide = bracket(a, cell.lo[a], cell.hi[a], start);
      r.evals += wide.evals;
      if (wide.best.valid() && (!r.best.valid() || wide.best.cost < r.best.cost))
        r.best = wide.best;
    }
    local.counters.evals += r.evals;
    if (r.best.valid()) {
      SplitObservation o;
      o.path = path;
      o.depth = depth;
      o.axis = s.axis;
      const double extent = static_cast<double>(cell.hi[s.axis]) - cell.lo[s.axis];
      o.fraction = (r.best.position - static_cast<double>(cell.lo[s.axis])) / extent;
      o.cost_ratio = r.best.cost / leaf;
      if (forecast_used) o.predicted = forecast->fraction;
      local.counters.observations.push_back(o);
    }
    local.counters.search_ms += timer.ms();
    return r;
  }

  // Exact counts of the split (straddlers on both sides) and its cost; primitives lying in
  // the plane go to the cheaper side unless already decided (ties: below, as golden).
  // The position of a kept plane's triangle bound in this frame (NaN without an anchor).
  float anchored(const ShapeNode& s) const {
    if (s.anchor == ShapeNode::kNoAnchor) return std::numeric_limits<float>::quiet_NaN();
    const Aabb t = triangles_[s.anchor / 2].bounds();
    return s.anchor % 2 ? t.hi[s.axis] : t.lo[s.axis];
  }

  struct Children {
    Aabb below_cell, above_cell, below_content, above_content;
  };

  // The one pass over a node's references at its plane: writes the children's references
  // (straddlers clipped to each child cell; primitives lying in the plane on the cheaper side
  // unless the search decided, ties below, as golden), their exact counts and the split's
  // cost into plan.split, and the plane's anchor (the first triangle whose own bound, not a
  // clipped one, lies on it). `below` and `above` have room for all references. A kept plane
  // that no longer pays (cost >= the leaf's) turns the plan into a rebuild.
  Children split_refs(Plan& plan, ShapeRef shape, std::span<const PrimRef> refs, const Aabb& cell,
                      PrimRef* below, PrimRef* above) const {
    BinnedSplit& split = plan.split;
    const int axis = split.axis;
    const float p = split.position;
    Children c;
    c.below_cell = c.above_cell = cell;
    c.below_cell.hi[axis] = p;
    c.above_cell.lo[axis] = p;
    std::size_t nb = 0, na = 0, planar = 0;
    // In-plane references go to the front of `above` until their side is known.
    for (const PrimRef& r : refs) {
      const float lo = r.bounds.lo[axis], hi = r.bounds.hi[axis];
      if (plan.anchor == ShapeNode::kNoAnchor && (lo == p || hi == p)) {
        const Aabb t = triangles_[r.id].bounds();
        if (t.lo[axis] == p)
          plan.anchor = 2 * r.id;
        else if (t.hi[axis] == p)
          plan.anchor = 2 * r.id + 1;
      }
      if (lo == p && hi == p) {
        above[na++] = r;
        ++planar;
      }
    }
    na = 0;
    std::size_t both = 0;
    // Non-planar references: below from the front of `below`, above after the planar ones.
    std::size_t ia = planar;
    for (const PrimRef& r : refs) {
      const float lo = r.bounds.lo[axis], hi = r.bounds.hi[axis];
      if (lo == p && hi == p) continue;
      if (!(lo < p)) {
        above[ia++] = r;
        c.above_content.extend(r.bounds);
      } else if (!(hi > p)) {
        below[nb++] = r;
        c.below_content.extend(r.bounds);
      } else {
        PrimRef& b = below[nb++];
        PrimRef& a = above[ia++];
        b.id = a.id = r.id;
        clip_triangle_split(triangles_[r.id], cell, r.bounds, axis, p, b.bounds, a.bounds,
                            ClipTightness::slab);
        c.below_content.extend(b.bounds);
        c.above_content.extend(a.bounds);
        ++both;
      }
    }
    const std::size_t only_above = ia - planar - both;
    const KdAxisCost axis_cost(cost_, cell, axis);
    const double cost_below = axis_cost(p, nb + planar, only_above + both);
    const double cost_above = axis_cost(p, nb, only_above + both + planar);
    if (!plan.planar_known) split.planar_below = !(cost_above < cost_below);
    split.cost = split.planar_below ? cost_below : cost_above;
    if (split.planar_below) {  // the planar references move from above's front to below's end
      for (std::size_t i = 0; i < planar; ++i) {
        below[nb++] = above[i];
        c.below_content.extend(above[i].bounds);
      }
      std::copy(above + planar, above + ia, above);
      ia -= planar;
    } else {
      for (std::size_t i = 0; i < planar; ++i) c.above_content.extend(above[i].bounds);
    }
    split.n_below = nb;
    split.n_above = ia;
    const double ratio = split.cost / cost_.leaf(refs.size());
    plan.split_ratio = shape.fresh ? ratio : shape.node().split_ratio;
    // A kept plane that no longer pays, or whose own cost grew beyond the tolerance since it
    // was chosen, is decided afresh by golden before any work goes into its children.
    if (!shape.fresh &&
        (!(ratio < 1) || (plan.split_ratio > 0 &&
                          ratio > plan.split_ratio * (1 + config_coherent_.split_tolerance))))
      plan.kind = Plan::rebuild;
    return c;
  }

  // The cost of an interior node from its children's (K_T + the children's costs weighted by
  // their cells' shares of the parent's area) and the node counts.
  Built combine(const Plan& plan, ShapeRef shape, const Aabb& cell, const Built& b,
                const Built& a) const {
    Aabb below_cell = cell, above_cell = cell;
    below_cell.hi[plan.split.axis] = plan.split.position;
    above_cell.lo[plan.split.axis] = plan.split.position;
    const double area = cell.half_area();
    Built built;
    built.cost = cost_.traversal +
                 (below_cell.half_area() * b.cost + above_cell.half_area() * a.cost) / area;
    built.add(b);
    built.add(a);
    if (shape.fresh)
      ++built.rebuilt;
    else if (plan.searched)
      ++built.reoptimised;
    else
      ++built.reused;
    return built;
  }

  bool drifted(ShapeRef shape, const Built& built, std::size_t n) const {
    if (shape.fresh) return false;
    const double reference = shape.node().built_ratio;
    return reference > 0 &&
           built.cost / cost_.leaf(n) > reference * (1 + config_coherent_.subtree_tolerance);
  }

  ShapeNode shape_node(const Plan& plan, ShapeRef shape, std::size_t n, const Aabb& content,
                       const Built& built) const {
    ShapeNode s;
    const int axis = plan.split.axis;
    s.axis = static_cast<std::int8_t>(axis);
    s.position = plan.split.position;
    s.planar_below = plan.split.planar_below;
    const double extent = static_cast<double>(content.hi[axis]) - content.lo[axis];
    s.fraction = extent > 0 ? static_cast<float>((s.position - content.lo[axis]) / extent) : 0.5f;
    s.prims = static_cast<std::uint32_t>(n);
    s.anchor = plan.anchor;
    s.split_ratio = plan.split_ratio;
    s.built_ratio =
        shape.fresh ? static_cast<float>(built.cost / cost_.leaf(n)) : shape.node().built_ratio;
    return s;
  }

  std::span<const Triangle> triangles_;
  const BuildConfig& config_;
  const CoherentConfig& config_coherent_;
  const SplitPredictor& predictor_;
  ThreadLocals& locals_;
  KdSplitCost cost_;
  int max_depth_;
  std::size_t max_leaf_;
};

}  // namespace

struct KdCoherentBuilder::State {
  BuildConfig config;
  CoherentConfig coherent;
  SplitPredictor predictor;
  ThreadLocals locals;
  Shape shape;  // the previous frame's tree
  std::size_t triangles = 0;
  std::size_t frame = 0;
  double rebuilt_share = 0;  // of the last frame's nodes
};

KdCoherentBuilder::KdCoherentBuilder(const BuildConfig& config, const PredictorConfig& predictor,
                                     const CoherentConfig& coherent)
    : state_(std::make_unique<State>()) {
  state_->config = config;
  state_->coherent = coherent;
  if (state_->config.builder.empty()) state_->config.builder = "golden";
  if (state_->config.builder != "golden")
    throw Error("--builder " + state_->config.builder,
                "coherent kd rebuilds rebuild drifted subtrees with golden (--builder golden)");
  state_->predictor = SplitPredictor(predictor);
}
KdCoherentBuilder::~KdCoherentBuilder() = default;
KdCoherentBuilder::KdCoherentBuilder(KdCoherentBuilder&&) noexcept = default;
KdCoherentBuilder& KdCoherentBuilder::operator=(KdCoherentBuilder&&) noexcept = default;

void KdCoherentBuilder::reset() {
  state_->predictor.clear();
  state_->shape.clear();
  state_->frame = 0;
}

std::unique_ptr<KdAccel> KdCoherentBuilder::next_frame(std::span<const Triangle> triangles,
                                                       CoherentFrameStats& stats) {
  State& s = *state_;
  if (triangles.empty()) throw Error("kd coherent rebuild", "the frame has no triangles");
  if (s.frame > 0 && triangles.size() != s.triangles)
    throw Error("kd coherent rebuild",
                "frame " + std::to_string(s.frame) + " has " + std::to_string(triangles.size()) +
                    " triangles, the previous frame " + std::to_string(s.triangles) +
                    " (every frame of a sequence must have the same triangles)");
  stats = CoherentFrameStats{};
  BuildConfig config = s.config;
  config.builder = "golden+coherent-" + predictor_name(s.predictor.config().kind);
  const ThreadLimit limit(config.threads);
  const Timer timer;
  Aabb bounds;
  for (const Triangle& t : triangles) bounds.extend(t.bounds());
  std::vector<PrimRef> refs(triangles.size());
  for (std::size_t i = 0; i < triangles.size(); ++i)
    refs[i] = {triangles[i].bounds(), static_cast<std::uint32_t>(i)};

  Shape first;  // golden's tree from scratch, its planes adopted
  if (s.shape.empty() || s.rebuilt_share > s.coherent.scratch_share) {
    stats.from_scratch = true;
    stats.reason = s.shape.empty()
                       ? "first frame"
                       : "the previous frame rebuilt " +
                             std::to_string(std::lround(100 * s.rebuilt_share)) + "% of the tree";
    const Timer golden;
    KdBuildResult built = build_kd_golden(triangles, bounds, s.config);
    const KdTree tree = take_kd_tree(built, bounds);
    first = shape_of(tree.nodes);
    stats.rebuild_ms += golden.ms();
  }
  for (Locals& l : s.locals) l.counters = Counters{};
  const CoherentFrame frame(triangles, s.config, s.coherent, s.predictor, s.locals);
  Built built;
  const ShapeRef root =
      first.empty() ? ShapeRef{s.shape.data(), 0, false} : ShapeRef{first.data(), 0, true};
  std::unique_ptr<Part> top = frame.task(root, refs, bounds, bounds, 0, kRootPath, built);
  Counters counters = frame.counters();
  if (!stats.from_scratch && built.rebuilt > 0 && built.reused + built.reoptimised == 0) {
    stats.from_scratch = true;
    stats.reason = "the root's cost drifted";
  }
  double error_sum = 0;
  for (const SplitObservation& o : counters.observations) {
    if (o.path == kRootPath) {
      const double lo = bounds.lo[o.axis], extent = static_cast<double>(bounds.hi[o.axis]) - lo;
      stats.root_axis = o.axis;
      stats.root_actual = lo + o.fraction * extent;
      if (o.predicted) stats.root_predicted = lo + *o.predicted * extent;
    }
    if (!o.predicted) continue;
    const double e = std::abs(o.fraction - *o.predicted);
    error_sum += e;
    stats.max_error = std::max(stats.max_error, e);
    ++stats.forecasts;
  }
  if (stats.forecasts > 0) stats.mean_error = error_sum / static_cast<double>(stats.forecasts);
  const Timer predict;
  std::sort(counters.observations.begin(), counters.observations.end(),
            [](const SplitObservation& a, const SplitObservation& b) { return a.path < b.path; });
  s.predictor.update(counters.observations);
  stats.predict_ms = predict.ms();

  const Timer layout;
  Shape shape;
  append_shape(*top, shape);
  std::unique_ptr<KdPartial> partial = to_partial(*top);
  KdTree tree = assemble_kd(*partial, bounds);
  s.shape = std::move(shape);
  s.triangles = triangles.size();
  ++s.frame;
  auto accel = std::make_unique<KdAccel>(std::move(tree), triangles, config, counters.evals, timer);
  stats.layout_ms = layout.ms();
  stats.search_ms = counters.search_ms;
  stats.rebuild_ms += counters.rebuild_ms;
  // The walk's CPU time not spent searching or rebuilding.
  stats.distribute_ms = std::max(0.0, counters.walk_ms - counters.search_ms - counters.rebuild_ms);
  s.rebuilt_share = stats.from_scratch
                        ? 0
                        : static_cast<double>(built.rebuilt) /
                              static_cast<double>(std::max<std::size_t>(
                                  1, built.rebuilt + built.reused + built.reoptimised));
  stats.reused_nodes = built.reused;
  stats.reoptimised_nodes = built.reoptimised;
  stats.rebuilt_nodes = built.rebuilt;
  stats.rebuilt_subtrees = built.rebuilds;
  stats.total_ms = timer.ms();
  stats.sah_cost = accel->stats().sah_cost.value_or(0);
  return accel;
}

}  // namespace splitray

#include "splitray/accel/bvh/kd_top_bvh.hpp"

#include <algorithm>
#include <numeric>

#include "splitray/accel/bvh/object_split.hpp"
#include "splitray/accel/triangle_clip.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"

namespace splitray {

namespace {

constexpr std::size_t kAssignChunk =
    4096;  // fixed chunks: the reference order never depends on threads

int add_kd_cells(const KdTree& tree, std::uint32_t node, const Aabb& box, int depth,
                 std::vector<TopCell>& cells) {
  const int index = static_cast<int>(cells.size());
  cells.push_back({box});
  const KdNode& n = tree.nodes[node];
  if (n.is_leaf() || depth <= 0) return index;
  const int axis = n.axis();
  Aabb below = box, above = box;
  below.hi[axis] = n.split;
  above.lo[axis] = n.split;
  cells[index].axis = axis;
  const int b = add_kd_cells(tree, node + 1, below, depth - 1, cells);
  const int a = add_kd_cells(tree, n.above(), above, depth - 1, cells);
  cells[index].child[0] = b;
  cells[index].child[1] = a;
  return index;
}

int add_box_cells(std::span<const Aabb> boxes, std::span<std::uint32_t> order,
                  std::vector<TopCell>& cells) {
  const int index = static_cast<int>(cells.size());
  cells.push_back({});
  if (order.size() == 1) {
    cells[index].box = boxes[order[0]];
    return index;
  }
  Aabb centers;
  for (std::uint32_t i : order) centers.extend(boxes[i].center());
  const int axis = centers.longest_axis();
  const std::size_t mid = order.size() / 2;
  std::nth_element(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(mid), order.end(),
                   [&](std::uint32_t a, std::uint32_t b) {
                     const float ca = boxes[a].center()[axis], cb = boxes[b].center()[axis];
                     return ca < cb || (ca == cb && a < b);
                   });
  const int l = add_box_cells(boxes, order.subspan(0, mid), cells);
  const int r = add_box_cells(boxes, order.subspan(mid), cells);
  cells[index].axis = axis;
  cells[index].child[0] = l;
  cells[index].child[1] = r;
  cells[index].box =
      merge(cells[static_cast<std::size_t>(l)].box, cells[static_cast<std::size_t>(r)].box);
  return index;
}

bool overlaps(const Aabb& a, const Aabb& b) { return !intersection(a, b).empty(); }

// Adds a reference of `prim` to every leaf cell below `cell` that the triangle reaches.
void assign(const Triangle& tri, const Aabb& tri_box, std::uint32_t prim,
            std::span<const TopCell> cells, std::span<const std::int32_t> leaf_of, int cell,
            std::vector<std::pair<std::uint32_t, BvhRef>>& out) {
  const TopCell& c = cells[static_cast<std::size_t>(cell)];
  if (c.leaf()) {
    const Aabb clipped = clip_triangle_bounds(tri, c.box);
    if (!clipped.empty())
      out.push_back(
          {static_cast<std::uint32_t>(leaf_of[static_cast<std::size_t>(cell)]), {clipped, prim}});
    return;
  }
  for (const std::int32_t child : c.child)
    if (overlaps(tri_box, cells[static_cast<std::size_t>(child)].box))
      assign(tri, tri_box, prim, cells, leaf_of, child, out);
}

int top_depth(std::span<const TopCell> cells, int cell) {
  const TopCell& c = cells[static_cast<std::size_t>(cell)];
  return c.leaf() ? 0 : 1 + std::max(top_depth(cells, c.child[0]), top_depth(cells, c.child[1]));
}

std::unique_ptr<BvhPiece> assemble(std::span<const TopCell> cells, int cell,
                                   std::span<const std::int32_t> leaf_of,
                                   std::vector<std::unique_ptr<BvhPiece>>& expanded) {
  const TopCell& c = cells[static_cast<std::size_t>(cell)];
  if (c.leaf())
    return std::move(expanded[static_cast<std::size_t>(leaf_of[static_cast<std::size_t>(cell)])]);
  auto a = assemble(cells, c.child[0], leaf_of, expanded);
  auto b = assemble(cells, c.child[1], leaf_of, expanded);
  if (!a || !b) return a ? std::move(a) : std::move(b);
  auto piece = std::make_unique<BvhPiece>();
  // Refit: the top node's box is the union of what its children really hold.
  piece->nodes.push_back(
      BvhNode::make_interior(merge(a->nodes[0].box(), b->nodes[0].box()), c.axis));
  piece->kids[0] = std::move(a);
  piece->kids[1] = std::move(b);
  return piece;
}

}  // namespace

std::vector<TopCell> top_cells_from_kd(const KdTree& tree, int depth) {
  std::vector<TopCell> cells;
  if (!tree.nodes.empty()) add_kd_cells(tree, 0, tree.bounds, depth, cells);
  return cells;
}

std::vector<TopCell> top_cells_from_boxes(std::span<const Aabb> boxes) {
  if (boxes.empty()) throw Error("kd-top bvh", "no leaf boxes given");
  std::vector<std::uint32_t> order(boxes.size());
  std::iota(order.begin(), order.end(), 0u);
  std::vector<TopCell> cells;
  add_box_cells(boxes, order, cells);
  return cells;
}

LeafExpander parse_leaf_expander(const std::string& name) {
  if (name == "binned") return LeafExpander::binned;
  if (name == "sbvh") return LeafExpander::sbvh;
  if (name == "embree") return LeafExpander::embree;
  throw Error("--expander", "'" + name + "' is not a leaf expander (known: binned, sbvh, embree)");
}

Bvh build_top_bvh(std::span<const Triangle> triangles, std::span<const TopCell> cells,
                  LeafExpander expander, const BvhBuildOptions& options, TopBvhStats* stats) {
  if (cells.empty()) throw Error("kd-top bvh", "the top has no cells");
  Timer total;
  std::vector<std::int32_t> leaf_of(cells.size(), -1);
  std::vector<int> leaf_cells;
  for (std::size_t i = 0; i < cells.size(); ++i)
    if (cells[i].leaf()) {
      leaf_of[i] = static_cast<std::int32_t>(leaf_cells.size());
      leaf_cells.push_back(static_cast<int>(i));
    }

  // Step 2: references per leaf cell, in triangle order.
  Timer timer;
  const std::size_t chunks = (triangles.size() + kAssignChunk - 1) / kAssignChunk;
  std::vector<std::vector<std::pair<std::uint32_t, BvhRef>>> found(chunks);
  parallel_for_each_index(chunks, [&](std::size_t k) {
    const std::size_t end = std::min(triangles.size(), (k + 1) * kAssignChunk);
    for (std::size_t i = k * kAssignChunk; i < end; ++i) {
      const std::size_t before = found[k].size();
      const Aabb box = triangles[i].bounds();
      if (overlaps(box, cells[0].box))
        assign(triangles[i], box, static_cast<std::uint32_t>(i), cells, leaf_of, 0, found[k]);
      if (found[k].size() == before)
        throw Error("kd-top bvh",
                    "triangle " + std::to_string(i) + " lies outside every leaf cell");
    }
  });
  std::vector<std::vector<BvhRef>> refs(leaf_cells.size());
  std::vector<std::size_t> counts(leaf_cells.size(), 0);
  for (const auto& chunk : found)
    for (const auto& [leaf, ref] : chunk) ++counts[leaf];
  for (std::size_t l = 0; l < refs.size(); ++l) refs[l].reserve(counts[l]);
  for (auto& chunk : found) {
    for (const auto& [leaf, ref] : chunk) refs[leaf].push_back(ref);
    std::vector<std::pair<std::uint32_t, BvhRef>>().swap(chunk);
  }
  const double assign_ms = timer.ms();

  // Step 3: expand every non-empty cell; each fits below the top within the stack depth.
  timer.reset();
  const int depth = top_depth(cells, 0);
  BvhBuildOptions leaf_options = options;
  leaf_options.max_depth = std::max(1, std::min(options.max_depth, 64) - depth);
  leaf_options.measure = SplitMeasure::interior(cells[0].box);  // as Bvh::build, for the scene
  std::vector<std::unique_ptr<BvhPiece>> expanded(leaf_cells.size());
  parallel_for_each_index(leaf_cells.size(), [&](std::size_t l) {
    if (refs[l].empty()) return;
    BvhBuildResult built;
    switch (expander) {
      case LeafExpander::binned: {
        const RefBounds bounds = ref_bounds(refs[l]);
        built = build_bvh_binned(triangles, std::move(refs[l]), bounds, leaf_options);
        break;
      }
      case LeafExpander::sbvh: {
        const RefBounds bounds = ref_bounds(refs[l]);
        built = build_bvh_sbvh(triangles, std::move(refs[l]), bounds, leaf_options);
        break;
      }
      case LeafExpander::embree:
        built = build_bvh_embree(triangles, std::move(refs[l]), leaf_options, true);
        break;
    }
    expanded[l] = std::move(built.root);
  });
  const double expand_ms = timer.ms();

  // Step 4: the top as interior nodes over the expanded cells, boxes refitted bottom-up.
  std::size_t ref_count = 0, empty = 0;
  for (std::size_t l = 0; l < leaf_cells.size(); ++l) {
    ref_count += counts[l];
    if (counts[l] == 0) ++empty;
  }
  auto root = assemble(cells, 0, leaf_of, expanded);
  if (!root) throw Error("kd-top bvh", "no triangles to build on");
  Bvh bvh = Bvh::from_pieces(triangles, *root);
  if (stats) {
    stats->top_leaves = leaf_cells.size();
    stats->empty_top_leaves = empty;
    stats->refs = ref_count;
    stats->top_depth = depth;
    stats->assign_ms = assign_ms;
    stats->expand_ms = expand_ms;
    stats->total_ms = total.ms();
  }
  return bvh;
}

Bvh build_kd_top_bvh(std::span<const Triangle> triangles, int depth, LeafExpander expander,
                     const BuildConfig& config, TopBvhStats* stats) {
  if (triangles.empty()) throw Error("kd-top bvh", "no triangles to build on");
  Aabb bounds;
  for (const Triangle& t : triangles) bounds.extend(t.bounds());
  BuildConfig top_config = config.with_sah(kSharedSah);  // the BVH's constants, not kd's
  top_config.max_depth = std::max(depth, 1);
  KdBuildResult kd = build_kd_sah(triangles, bounds, top_config);
  const std::vector<TopCell> cells = top_cells_from_kd(take_kd_tree(kd, bounds), depth);
  return build_top_bvh(triangles, cells, expander, BvhBuildOptions::from(config), stats);
}

}  // namespace splitray

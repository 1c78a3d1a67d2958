#pragma once
// The top of a kd-tree turned into a BVH (paper 003 §6.4), the way the neural builder's
// fixed-depth top becomes a ray-tracing hierarchy:
//   1. the top's leaf cells are disjoint boxes that cover the scene;
//   2. every triangle is referenced from each leaf cell it overlaps, with its bounds clipped
//      to the cell (accel/triangle_clip.hpp, conservative), so no cell's bounds reach into
//      another;
//   3. each cell's references are expanded into a BVH by one of our builders (binned, sbvh)
//      or by Embree's custom builder (rtcBuildBVH);
//   4. the top's boxes are refitted bottom-up to their children, cells without triangles
//      dropped.
// The result is an ordinary Bvh (same traversal, refit, statistics).
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "splitray/accel/bvh/bvh.hpp"
#include "splitray/accel/kd/kd_build.hpp"

namespace splitray {

// A binary tree of cells, root at index 0; a leaf has no children.
struct TopCell {
  Aabb box;
  int axis = 0;  // split axis of an interior cell
  std::int32_t child[2] = {-1, -1};
  bool leaf() const { return child[0] < 0; }
};

// The cells of a kd-tree down to `depth` levels below its root.
std::vector<TopCell> top_cells_from_kd(const KdTree& tree, int depth);
// A tree over given disjoint leaf boxes (median splits of their centres); together the boxes
// must cover every triangle that will be assigned to them.
std::vector<TopCell> top_cells_from_boxes(std::span<const Aabb> boxes);

enum class LeafExpander { binned, sbvh, embree };
LeafExpander parse_leaf_expander(const std::string& name);  // throws Error on an unknown name

struct TopBvhStats {
  std::size_t top_leaves = 0;        // leaf cells
  std::size_t empty_top_leaves = 0;  // leaf cells no triangle reaches (dropped)
  std::size_t refs = 0;              // references after assignment (>= triangles)
  int top_depth = 0;
  double assign_ms = 0, expand_ms = 0, total_ms = 0;
};

// Steps 2-4 over a given top. Throws Error when a triangle lies outside every leaf cell.
Bvh build_top_bvh(std::span<const Triangle> triangles, std::span<const TopCell> cells,
                  LeafExpander expander, const BvhBuildOptions& options,
                  TopBvhStats* stats = nullptr);

// The whole pipeline with the top of build_kd_sah (stopped at `depth`) as the cells.
Bvh build_kd_top_bvh(std::span<const Triangle> triangles, int depth, LeafExpander expander,
                     const BuildConfig& config, TopBvhStats* stats = nullptr);

}  // namespace splitray

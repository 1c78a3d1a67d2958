#pragma once
// The parts every BVH builder shares: the 32-byte node, primitive references (a triangle id
// with bounds that may be clipped to a region), settings, and the builders themselves.
// A builder returns a Piece tree (piece_tree.hpp) that Bvh lays out.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/accel/bvh/piece_tree.hpp"
#include "splitray/core/aabb.hpp"
#include "splitray/core/triangle.hpp"

namespace splitray {

// The binary node every builder produces; the children of a node are stored side by side.
struct alignas(32) BvhNode {
  Vec3 lo;
  std::uint32_t index =
      0;  // interior: first child (the second is index + 1); leaf: first reference
  Vec3 hi;
  std::uint32_t meta = 0;  // leaf: reference count (> 0); interior: split axis << 30

  static constexpr std::uint32_t kCountMask = (1u << 30) - 1;
  bool leaf() const { return (meta & kCountMask) != 0; }
  std::uint32_t count() const { return meta & kCountMask; }
  int axis() const { return static_cast<int>(meta >> 30); }
  Aabb box() const { return {lo, hi}; }

  static BvhNode make_leaf(const Aabb& box, std::uint32_t first, std::uint32_t count) {
    return {box.lo, first, box.hi, count};
  }
  static BvhNode make_interior(const Aabb& box, int axis, std::uint32_t first_child = 0) {
    return {box.lo, first_child, box.hi, static_cast<std::uint32_t>(axis) << 30};
  }
};
static_assert(sizeof(BvhNode) == 32);

struct BvhNodeTraits {
  static bool is_leaf(const BvhNode& n) { return n.leaf(); }
  static std::uint32_t child(const BvhNode& n) { return n.index; }
  static void set_child(BvhNode& n, std::uint32_t c) { n.index = c; }
  static void shift_leaf(BvhNode& n, std::uint32_t by) { n.index += by; }
};

using BvhPiece = Piece<BvhNode>;

// A triangle, or the part of it inside some region, and the bounds of that part. 32 bytes:
// the builders move many of them and read lo and hi as SIMD rows.
struct alignas(32) BvhRef {
  Aabb box;
  std::uint32_t prim = 0;
  Vec3 center() const { return (box.lo + box.hi) * 0.5f; }
};

std::vector<BvhRef> make_prim_refs(std::span<const Triangle> triangles);  // whole triangles

// What the builders rate a box's chance of being entered by, relative to its parent's:
// measure(child) / measure(parent). The SAH's measure, the half area, counts rays from outside
// the scene. Most rays start inside it (shadow, diffuse and reflected rays, a camera in a
// room), and a ray that starts in a box enters it whatever its direction. With origins uniform
// in the scene's box S and directions uniform (the assumption of Fabianowski, Fowler &
// Dingliana 2009), the (origin, direction) pairs whose ray enters a convex box X number half the
// integral, over the lines that meet X, of their chords in S and in X. By Cauchy's and
// Crofton's formulas, with the chord in S taken at its mean 4 V_S / A_S, that is the fraction
// A_X / (2 A_S) + V_X / (2 V_S) of all pairs: so the measure is the half area plus the volume
// times half_area(S) / volume(S) (`volume_weight`; 0, the SAH alone, for a flat scene).
// Measured against the SAH, relative to Embree in the same runs (docs/experiments.md, builds
// round 7): the untuned rooms' primary rays up to 15% faster, the benchmark meshes level.
struct SplitMeasure {
  float volume_weight = 0;
  // The measure for rays that start inside `scene` (the box of every triangle).
  // (A scene too thin for the ratio to be finite is flat to it.)
  static SplitMeasure interior(const Aabb& scene) {
    const Vec3 e = scene.extent();
    const float volume = e.x * e.y * e.z;
    const float weight = scene.empty() || !(volume > 0) ? 0.0f : scene.half_area() / volume;
    return {std::isfinite(weight) ? weight : 0.0f};
  }
  float operator()(const Aabb& box) const {
    if (box.empty()) return 0;
    const Vec3 e = box.extent();
    return box.half_area() + volume_weight * (e.x * e.y * e.z);
  }
};

struct BvhBuildOptions {
  float traversal_cost = 15;     // SAH K_T
  float intersection_cost = 20;  // SAH K_I, per block of leaf_block triangles (tested at once)
  int leaf_block = 8;            // triangles a leaf tests together (one block of eight lanes)
  int min_leaf = 1;              // nodes with this many references or fewer are leaves
  int max_leaf = 8;              // nodes with more are split whenever they can be
  int bins = 32;                 // SAH bins per axis for object splits
  int spatial_bins = 16;         // SBVH: bins per axis for spatial splits (as Embree), at most
  int max_depth = 64;            // at most 64 (the traversal stack)
  float sbvh_alpha = 1e-5f;      // SBVH: try spatial splits when overlap / root area > alpha
  float sbvh_overlap = 0.2f;     // SBVH: ... and overlap / node area >= this
  SplitMeasure measure;          // the SAH's half area unless set for a scene (Bvh::build)

  static BvhBuildOptions from(const BuildConfig& config);
};

// The size from which a builder's subtrees become tasks of their own (pieces, built in
// parallel), for a build of `total` references: 4096, and for small meshes an eighth of them
// (at least 512), so that those are built on every thread too (walking_cat's 2,576 triangles
// took as long on 2 threads as on 1). It depends on the mesh only, so the layout never depends
// on the thread count.
inline std::size_t bvh_task_refs(std::size_t total) {
  return std::clamp<std::size_t>(total / 8, 512, 4096);
}

// Whether a node of `n` references within `box` is made a leaf before any split is sought:
// too few references, too deep, or a box without area that a leaf can hold. Such a box is a
// segment or a point, so its triangles are degenerate and never hit (core/triangle.hpp), and
// the SAH, whose child areas are divided by the node's, cannot rate a split of it (such splits
// made 2,080 more leaves of the conference room).
inline bool bvh_leaf_at_once(const BvhBuildOptions& o, std::size_t n, const Aabb& box, int depth) {
  return n <= static_cast<std::size_t>(o.min_leaf) || depth >= o.max_depth ||
         (n <= static_cast<std::size_t>(o.max_leaf) && !(box.half_area() > 0));
}

struct BvhBuildResult {
  std::unique_ptr<BvhPiece> root;
  std::uint64_t cost_evals = 0;
};

struct RefBounds;

// Binned SAH over reference centres (Wald 2007). `bounds`: ref_bounds(refs), which the caller
// has made for the split measure (object_split.hpp).
BvhBuildResult build_bvh_binned(std::span<const Triangle> triangles, std::vector<BvhRef> refs,
                                const RefBounds& bounds, const BvhBuildOptions& options);
// Spatial-split BVH (Stich, Friedrich & Dietrich 2009): binned object splits, and spatial
// splits with reference splitting and unsplitting where the children would overlap by more
// than sbvh_alpha of the root's area; at most twice as many references as input.
BvhBuildResult build_bvh_sbvh(std::span<const Triangle> triangles, std::vector<BvhRef> refs,
                              const RefBounds& bounds, const BvhBuildOptions& options);
// Embree's custom builder (rtcBuildBVH, high quality with spatial splits through our
// triangle splitting when `spatial`), converted to our nodes.
BvhBuildResult build_bvh_embree(std::span<const Triangle> triangles, std::vector<BvhRef> refs,
                                const BvhBuildOptions& options, bool spatial);

}  // namespace splitray

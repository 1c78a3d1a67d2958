#pragma once
// What every kd builder produces and shares: the finished tree (the builders write compact
// nodes directly, kd_emit.hpp) or a temporary pointer tree of KdBuildNode (simple builders,
// such as the tests' reference ones), which flatten_kd() lays out as compact 8-byte nodes,
// depth first; either way the final tree depends only on the build decisions, never on the
// thread count or order.
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/accel/kd/kd_tree.hpp"

namespace splitray {

struct KdBuildNode {
  int axis = -1;  // -1 = leaf
  float split = 0;
  std::unique_ptr<KdBuildNode> below, above;  // interior: children (below = coordinate < split)
  std::vector<std::uint32_t> prims;           // leaf: triangle ids
};

struct KdBuildResult {
  std::unique_ptr<KdBuildNode> root;  // or, from builders that lay out nodes themselves:
  std::optional<KdTree> tree;         // the finished tree (then root is null)
  std::uint64_t cost_evals = 0;       // SAH cost evaluations
};

// Each builder: triangles, their common bounding box (the root cell), settings.
using KdBuilder = KdBuildResult (*)(std::span<const Triangle>, const Aabb&, const BuildConfig&);

KdBuildResult build_kd_sah(std::span<const Triangle>, const Aabb&,
                           const BuildConfig&);  // event sweep
KdBuildResult build_kd_golden(std::span<const Triangle>, const Aabb&,
                              const BuildConfig&);  // paper 000
KdBuildResult build_kd_binned(std::span<const Triangle>, const Aabb&, const BuildConfig&);  // bins

// Lays out a builder's tree as compact nodes, depth first (below child right after its parent),
// leaves' references in the same order. Throws Error when the tree exceeds the node format.
KdTree flatten_kd(const KdBuildNode& root, const Aabb& bounds);

// The tree of a build result: `tree` when the builder made it, else flatten_kd(root).
KdTree take_kd_tree(KdBuildResult& built, const Aabb& bounds);

}  // namespace splitray

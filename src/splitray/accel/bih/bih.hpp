#pragma once
// Bounding interval hierarchy (Wächter & Keller 2006; paper 004): a binary tree whose nodes
// store the split axis and two clip planes, the maximum of the left child's primitives and
// the minimum of the right child's, in 12 bytes. Every primitive is in exactly one leaf, so
// nothing is clipped and nothing is duplicated. A node may also have a single child whose
// primitives lie between its two planes, cutting off empty space on both sides (the fifth
// traversal case); builders insert it where the SAH says it pays.
#include <bit>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/core/aabb.hpp"
#include "splitray/core/triangle.hpp"

namespace splitray {

struct BihNode {
  // bits 0-1: axis, 3 = leaf. Interior: bit 2 = one child, bits 3-31 = first child (the
  // second, if any, follows it). Leaf: bits 2-31 = first primitive, clip[0] holds the count.
  std::uint32_t bits = 3;
  float clip[2] = {0,
                   0};  // interior: left max and right min (one child: its lower and upper bound)

  bool leaf() const { return (bits & 3u) == 3u; }
  int axis() const { return static_cast<int>(bits & 3u); }
  bool one_child() const { return (bits & 4u) != 0; }
  std::uint32_t child() const { return bits >> 3; }
  std::uint32_t first() const { return bits >> 2; }
  std::uint32_t count() const { return std::bit_cast<std::uint32_t>(clip[0]); }

  static BihNode make_leaf(std::uint32_t first, std::uint32_t count) {
    return {(first << 2) | 3u, {std::bit_cast<float>(count), 0.0f}};
  }
  static BihNode make_interior(int axis, float left_max, float right_min, std::uint32_t child = 0) {
    return {(child << 3) | static_cast<std::uint32_t>(axis), {left_max, right_min}};
  }
  static BihNode make_one_child(int axis, float lo, float hi, std::uint32_t child = 0) {
    return {(child << 3) | 4u | static_cast<std::uint32_t>(axis), {lo, hi}};
  }
};
static_assert(sizeof(BihNode) == 12);

enum class BihHeuristic {
  global,  // Wächter & Keller: split candidates from a global regular grid over the scene
  median,  // object median along the longest axis of the centres
  middle,  // spatial middle of the longest axis of the node's bounds
  sah,     // binned SAH over the child intervals
};

BihHeuristic parse_bih_heuristic(const std::string& name);  // throws Error on an unknown name
std::vector<std::string> bih_builder_names();               // the default first

struct BihBuildOptions {
  BihHeuristic heuristic = BihHeuristic::global;
  float traversal_cost = 15;
  float intersection_cost = 20;
  int leaf_size = 1;     // leaves hold at most this many primitives (unless the depth limit hits)
  int max_leaf_sah = 8;  // sah: nodes up to this size become leaves when that is cheaper
  int bins = 64;         // sah
  int max_depth = 64;    // at most 64 (the traversal stack)
  bool one_child_nodes = true;

  static BihBuildOptions from(const BuildConfig& config, BihHeuristic heuristic);
};

class Bih {
 public:
  Bih() = default;
  static Bih build(std::span<const Triangle> triangles, const BihBuildOptions& options);

  Hit intersect(const Ray& ray) const;
  bool occluded(const Ray& ray) const;

  void fill_stats(AccelStats& stats, float traversal_cost, float intersection_cost) const;
  std::span<const BihNode> nodes() const { return nodes_; }
  const Aabb& bounds() const { return scene_; }
  std::uint64_t cost_evals() const { return cost_evals_; }

 private:
  std::vector<BihNode> nodes_;      // root at 0
  std::vector<std::uint32_t> ids_;  // triangle id of each leaf slot
  std::vector<Triangle> tris_;      // triangles in leaf order
  Aabb scene_;
  float magnitude_ = 0;
  std::uint64_t cost_evals_ = 0;
};

}  // namespace splitray

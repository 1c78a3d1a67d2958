#pragma once
// The traversal layout of a Bvh: the binary tree collapsed into nodes of up to eight children
// whose boxes are stored axis by axis (32 bytes per child), so that one SIMD slab test checks
// all eight and a ray needs a third of the dependent memory loads of the binary tree.
// Collapsing keeps every binary leaf, so the references and the answers are the same.
#include <cstdint>
#include <span>
#include <vector>

#include "splitray/accel/bvh/bvh_build.hpp"
#include "splitray/core/triangle.hpp"

namespace splitray {

inline constexpr int kWideWidth = 8;

struct alignas(64) WideNode {
  // planes[0..2] = lower x, y, z; planes[3..5] = upper x, y, z; empty slots have lower > upper.
  float planes[6][kWideWidth];
  std::uint32_t child[kWideWidth];  // interior: wide node index; leaf: first reference
  std::uint32_t count[kWideWidth];  // leaf: references (> 0); interior or empty: 0
};
static_assert(sizeof(WideNode) == 256);

class WideBvh {
 public:
  // Collapses `nodes` (root at 0, children side by side), greedily opening the child with the
  // largest surface area until a node has eight children.
  void collapse(std::span<const BvhNode> nodes);
  // Copies the binary tree's boxes again (after a refit: same topology).
  void update_boxes(std::span<const BvhNode> nodes);

  // Closest hit (hit.t = tmax on entry) or any hit, as Bvh::intersect / occluded.
  void intersect(const Ray& ray, const Aabb& scene, float magnitude, std::span<const Triangle> tris,
                 std::span<const std::uint32_t> ids, Hit& hit) const;
  bool occluded(const Ray& ray, const Aabb& scene, float magnitude, std::span<const Triangle> tris) const;

  std::size_t bytes() const { return nodes_.size() * sizeof(WideNode) + source_.size() * sizeof(std::uint32_t); }
  std::span<const WideNode> nodes() const { return nodes_; }

 private:
  std::vector<WideNode> nodes_;           // root at 0
  std::vector<std::uint32_t> source_;     // binary node of each slot (kInvalidId: empty)
};

}  // namespace splitray

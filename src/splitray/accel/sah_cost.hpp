#pragma once
// The SAH cost of a built tree, computed the same way for every structure from its nodes:
//   C = sum_interior K_T * A(n)/A(root) + sum_leaves K_I * prims(l) * A(l)/A(root)
// so that the costs of different builders and structures are comparable. Its two sums, the
// expected node steps and triangle tests of a ray through the root (C = K_T steps + K_I tests),
// are kept apart too: `splitray bench kd-costs` fits measured trace times to them.
#include <cstddef>

#include "splitray/accel/accel.hpp"
#include "splitray/core/aabb.hpp"

namespace splitray {

class SahCost {
 public:
  SahCost(const Aabb& root, float traversal_cost, float intersection_cost)
      : inv_root_area_(root.half_area() > 0 ? 1.0 / root.half_area() : 0.0),
        traversal_cost_(traversal_cost),
        intersection_cost_(intersection_cost) {}

  void interior(const Aabb& box) {
    cost_ += traversal_cost_ * box.half_area() * inv_root_area_;
    steps_ += box.half_area() * inv_root_area_;
  }
  void leaf(const Aabb& box, std::size_t prims) {
    cost_ += intersection_cost_ * static_cast<double>(prims) * box.half_area() * inv_root_area_;
    tests_ += static_cast<double>(prims) * box.half_area() * inv_root_area_;
  }
  double value() const { return cost_; }

  // The cost, its two sums and the constants it was computed with, into `stats`.
  void report(AccelStats& stats) const {
    stats.sah_cost = cost_;
    stats.sah_node_steps = steps_;
    stats.sah_triangle_tests = tests_;
    stats.sah_traversal_cost = static_cast<float>(traversal_cost_);
    stats.sah_intersection_cost = static_cast<float>(intersection_cost_);
  }

 private:
  double inv_root_area_;
  double traversal_cost_, intersection_cost_;
  double cost_ = 0;
  double steps_ = 0, tests_ = 0;
};

}  // namespace splitray

#pragma once
// The neural point kd-tree (paper 003 §6.3, internal): a top inferred by the VVH model from M
// uniformly drawn points, populated with all points, each leaf cell expanded by the VVH builder
// (or PointTreeConfig::expand: vvh, sah, median) with that cell as its root.
#include <span>

#include "splitray/accel/neural/neural_model.hpp"
#include "splitray/accel/neural/neural_top.hpp"
#include "splitray/query/point_build.hpp"

namespace splitray {

struct NeuralPointBuild {
  PointBuildOutput tree;
  NeuralTop top;
  double sampling_ms = 0;
};

// The top of `model` (a VVH model) over `points` (root cell `bounds`) with the VVH constants and
// radius of `config`.
NeuralTop infer_point_top(const NeuralModel& model, std::span<const Vec3> points,
                          const Aabb& bounds, const PointTreeConfig& config, float radius,
                          double* sampling_ms = nullptr);

// Population and expansion of a given top.
PointBuildOutput expand_point_top(std::span<const Vec3> points, const Aabb& bounds,
                                  const NeuralTop& top, const PointTreeConfig& config,
                                  float radius);

// The whole build; the model is config.neural.model or the shipped default vvh model.
NeuralPointBuild build_neural_point_tree(std::span<const Vec3> points, const Aabb& bounds,
                                         const PointTreeConfig& config, float radius);

}  // namespace splitray

#pragma once
// --builder neural for --accel kd and bvh (paper 003 §4.3-4.5, §6.4): a top of fixed depth
// inferred by the network from M area-weighted surface samples, populated with all triangles,
// its leaf cells expanded by a conventional builder (BuildConfig::expand; default: the
// structure's own default builder, so that `neural` and that builder differ only in the top).
#include <memory>
#include <span>
#include <string>

#include "splitray/accel/accel.hpp"
#include "splitray/accel/kd/kd_build.hpp"
#include "splitray/accel/neural/neural_model.hpp"
#include "splitray/accel/neural/neural_top.hpp"

namespace splitray {

// The model of `config.neural.model`, or the shipped default of `cost` when empty. Throws Error
// when the file is absent or invalid, or when it was trained for the other cost.
NeuralModel load_neural_model(const std::string& path, NeuralCost cost);

// Sampling and greedy inference over triangles with SAH constants from `config`.
struct TriangleTop {
  NeuralTop top;
  double sampling_ms = 0;  // the area prefix sums (O(N)) and the M draws
};
TriangleTop infer_triangle_top(const NeuralModel& model, std::span<const Triangle> triangles,
                               const Aabb& bounds, const BuildConfig& config);

// Population + expansion into one kd-tree: every leaf cell gets the triangles whose bounds
// reach it and is built by `expand` with the cell as its root box; the subtrees are laid out
// beneath the top's nodes depth first. Adds the builders' SAH evaluations to `cost_evals`.
KdTree expand_top_kd(std::span<const Triangle> triangles, const NeuralTop& top, KdBuilder expand,
                     const BuildConfig& config, std::uint64_t* cost_evals = nullptr);

std::unique_ptr<Accel> make_neural_kd(std::span<const Triangle> triangles,
                                      const BuildConfig& config);
std::unique_ptr<Accel> make_neural_bvh(std::span<const Triangle> triangles,
                                       const BuildConfig& config);

}  // namespace splitray

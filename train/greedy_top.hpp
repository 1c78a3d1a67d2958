#pragma once
// The baseline the neural top is measured against, and the cost both are measured with:
// a greedy SAH/VVH top of the same depth built on the same point sample, choosing each split
// by an exact sweep over the sample (the same local cost of Eq. 4 that infer_neural_top uses
// to pick an axis), and the recursive cost (Eq. 4) of any top evaluated on that sample.
#include <span>

#include "splitray/accel/neural/neural_top.hpp"

namespace splitray::train {

// `options.max_depth` levels (0 = the root alone); counts scaled by population / samples as in
// inference.
NeuralTop greedy_top(std::span<const Vec3> samples, const Aabb& root,
                     const NeuralTopOptions& options);

// Eq. 4 over the top with leaves q = c_i N (Eq. 5/6), N counted on `samples` (scaled), divided
// by the cost of the root as a single leaf (so 1 = no split helps).
double normalised_top_cost(const NeuralTop& top, std::span<const Vec3> samples,
                           const NeuralTopOptions& options);

}  // namespace splitray::train

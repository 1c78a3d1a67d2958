#pragma once
// The cost the neural top and its baseline, the greedy top on the same point sample
// (greedy_top, neural_top.hpp), are measured with: the recursive cost (Eq. 4) of any top
// evaluated on that sample.
#include <span>

#include "splitray/accel/neural/neural_top.hpp"

namespace splitray::train {

// Eq. 4 over the top with leaves q = c_i N (Eq. 5/6), N counted on `samples` (scaled), divided
// by the cost of the root as a single leaf (so 1 = no split helps).
double normalised_top_cost(const NeuralTop& top, std::span<const Vec3> samples,
                           const NeuralTopOptions& options);

}  // namespace splitray::train

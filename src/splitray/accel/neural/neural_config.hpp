#pragma once
// The settings of builder "neural" (paper 003), one type shared by the triangle structures'
// BuildConfig and the point trees' configs.
#include <string>

namespace splitray {

// Inferred-top nodes with fewer primitives than this (estimated from the samples) are left to
// the expansion builder, whose exact decisions beat sampled ones on small cells.
inline constexpr int kNeuralTopMinPrims = 4096;

struct NeuralConfig {
  // The model file; empty = the shipped default for the cost (models/sah.bin, models/vvh.bin).
  std::string model;
  // The builder that expands the inferred top's leaf cells; empty = the structure's default
  // (vvh for point trees).
  std::string expand;
  // Inferred-top nodes with fewer primitives or points than this are left to the expansion
  // builder; 0 = every node down to the model's depth.
  int top_min = kNeuralTopMinPrims;
  // The top from an exact greedy sweep over the same samples instead of the network (the
  // baseline of paper 003 Fig. 3: what the samples alone give).
  bool greedy_top = false;
};

}  // namespace splitray

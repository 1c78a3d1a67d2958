#pragma once
// The libtorch side of the neural builder's training (paper 003 §4.2, §5): the encoders, the
// differentiable recursive tree cost over the full expansion of all axis choices, its two
// custom gradients, and the export into the plain C++ model format (neural_model.hpp).
// Only this header's translation units include <torch/torch.h> (each costs ~25 s to build).
#include <torch/torch.h>

#include <vector>

#include "splitray/accel/neural/neural_model.hpp"
#include "train_data.hpp"

namespace splitray::train {

// Axis choice (§5.1): forward the hard minimum over each row of `costs` [n, k] (+inf marks
// an option that does not exist), backward the softmax of -costs / t over the row (the
// gradient of the negative LogSumExp -t log Σ exp(-c / t)).
torch::Tensor soft_min(const torch::Tensor& costs, double t);

// Primitive counts (§5.3): forward the exact `counts`, backward d count / d split = `slopes`
// (n / (ε + e): n points at distance ε to the next point the count would take in).
torch::Tensor replaced_count(const torch::Tensor& split, const torch::Tensor& counts,
                             const torch::Tensor& slopes);

// The replacement slopes for a split at `split` among `coords` (one axis): for the count
// below (coordinate < split) toward the nearest coordinate >= split, for the count above
// (negative) toward the nearest coordinate < split; 0 where there is none. `e` is in the
// units of `coords`.
struct CountSlopes {
  float below = 0, above = 0;
};
CountSlopes count_slopes(const std::vector<float>& coords, float split, float e);

// One level's encoder: per-point 1x1 convolutions (Linear on the scalar coordinate), mean
// pooling over each group's points, and the head; exactly encode_groups of neural_model.hpp.
struct EncoderImpl : torch::nn::Module {
  EncoderImpl(int width, int point_layers, int head_layers);
  // coords [P] in [1, 2], group [P] int64 in [0, groups): λ' per group [groups].
  torch::Tensor forward(const torch::Tensor& coords, const torch::Tensor& group, int64_t groups);
  std::vector<torch::nn::Linear> point, head;
};
TORCH_MODULE(Encoder);

struct NetImpl : torch::nn::Module {
  NetImpl(int depth, int width, int point_layers, int head_layers);
  std::vector<Encoder> levels;
};
TORCH_MODULE(Net);

NeuralModel export_model(Net& net, NeuralCost cost, int points, const std::string& metadata);
// The shapes of `model` (mean pooling) as a Net with its weights, e.g. to check the C++ pass.
Net import_model(const NeuralModel& model);

struct CostOptions {
  NeuralCost cost = NeuralCost::sah;
  int depth = 6;
  float traversal_cost = 15, intersection_cost = 20;
  double sharpness = 1;    // t of the soft minimum, on costs relative to the root leaf
  float count_eps = 0.5f;  // e of §5.3, in mean spacings of the node's points
  double huber = 0.1;      // the Huber parameter of Eq. 9
  int lookahead = 0;       // levels expanded below set.level (0 = down to depth)
};

struct SetLoss {
  torch::Tensor tree;       // (C̃)² of Eq. 8 for this set
  torch::Tensor bound;      // Σ γ L_b(λ') of Eq. 10 for this set
  double cost = 0;          // C̃: the minimum tree's cost relative to the root as one leaf
  std::size_t encoded = 0;  // network inputs (points × axes × nodes) of the expansion
};

// The full expansion over all axis choices for one set, from the encoder of set.level down
// `options.lookahead` levels (0: to options.depth); its last level's nodes are leaves.
SetLoss tree_loss(Net& net, const TrainSet& set, const CostOptions& options);

}  // namespace splitray::train

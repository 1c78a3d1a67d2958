#pragma once
// Training of the neural top builder (paper 003), without libtorch types so that the CLI
// front end and the reports stay out of the expensive translation unit.
#include <functional>
#include <vector>

#include "splitray/accel/neural/neural_model.hpp"
#include "train_data.hpp"

namespace splitray::train {

struct TrainOptions {
  NeuralCost cost = NeuralCost::sah;
  int depth = 6;
  int infer_points = 2048;  // M that inference draws (written into the model)
  int epochs = 30, batch = 8;
  double lr = 1e-3;
  int width = 32, point_layers = 1, head_layers = 2;
  float traversal_cost = 15, intersection_cost = 20;
  double sharpness = 1;
  float count_eps = 0.5f;
  int lookahead = 3;  // levels of full expansion below each set's level (0 = all, from level 0)
  int threads = 1;
  std::uint64_t seed = 1;
  bool evaluate_initial = true;  // epoch 0 of the report: the loss before any update
};

struct EpochStats {
  int epoch = 0;
  double loss = 0, tree = 0, bound = 0;  // means over the sets (Eq. 11, 8, 10)
  double cost = 0;                       // mean C̃ of the minimum trees
  double seconds = 0;                    // since the start of training
};

struct TrainResult {
  NeuralModel model;  // metadata left empty for the caller
  std::vector<EpochStats> epochs;
  std::size_t parameters = 0;
};

// `progress(fraction)` after every set, `epoch_done` after every epoch (both may be empty).
TrainResult train_model(const std::vector<TrainSet>& sets, const TrainOptions& options,
                        const std::function<void(double)>& progress = {},
                        const std::function<void(const EpochStats&)>& epoch_done = {});

}  // namespace splitray::train

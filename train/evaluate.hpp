#pragma once
// Tree quality of a trained model: per set, the greedy inference of the neural top
// (infer_neural_top, exactly what --builder neural runs) against a greedy SAH/VVH top of the
// same depth on the same samples, both costed by Eq. 4 on those samples.
#include <nlohmann/json.hpp>
#include <vector>

#include "train_data.hpp"
#include "trainer.hpp"

namespace splitray::train {

nlohmann::ordered_json evaluate(const NeuralModel& model, const std::vector<TrainSet>& sets,
                                const TrainOptions& options);

}  // namespace splitray::train

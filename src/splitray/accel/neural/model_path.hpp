#pragma once
// Where the shipped neural models (models/sah.bin, models/vvh.bin) are found at run time.
#include <string>
#include <vector>

#include "splitray/accel/neural/neural_model.hpp"

namespace splitray {

// The folders looked at, in order: $SPLITRAY_MODEL_DIR, the source tree's models/ (known at
// compile time), <prefix>/share/splitray/models next to the running executable.
std::vector<std::string> model_dirs();

// The default model file of a cost ("sah.bin" or "vvh.bin") in the first folder that has it;
// throws Error naming every place looked at when none has it.
std::string default_model_path(NeuralCost cost);
// The same, or "" when absent (for benchmarks that report the absence).
std::string find_default_model(NeuralCost cost);

}  // namespace splitray

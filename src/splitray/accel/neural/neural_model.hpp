#pragma once
// The neural builder's trained weights and their forward pass in plain C++ (paper 003 §4.1),
// so that neither the library nor the CLI needs libtorch. Written by the training program
// (train/, libtorch) and read here; tests check this forward pass against libtorch's.
//
// One encoder per tree level. An encoder sees ONE axis at a time (the weights are shared
// across the three axes, paper 003 §4.1): the input is the node's M points' coordinate on that
// axis, normalised to the active points' tight bounds and shifted into [1, 2], 0 for masked
// points (points outside the node's box). Per point, `point_layers` (1x1 convolutions: the
// first has in = 1) map that scalar to a feature vector; the features of the active points are
// pooled (max or mean over active points only); `head_layers` map the pooled vector to one
// number, the split offset λ' relative to the tight bounds (the last layer is linear; training
// keeps it in [0, 1] with the Huber penalty of Eq. 9-10; inference clamps it to [0, 1]).
//
// File format (little endian, all counts uint32, all numbers float32):
//   magic "SPLITRAY-NEURAL1" (16 bytes)
//   cost (0 = sah, 1 = vvh), depth (= number of levels), points M, pooling (0 = max, 1 = mean)
//   per level: point layer count, then per layer: in, out, activation, weight[out][in], bias[out]
//              head layer count, then the same per layer
//   activation: 0 = identity, 1 = relu
//   then a UTF-8 JSON text of uint32 length: free-form training metadata (meshes, epochs, ...)
// Readers reject other magics, counts over 4096, shapes that do not chain (the first point
// layer's in must be 1, each layer's in = the previous out, the first head in = the last point
// out, the last head out = 1), non-finite numbers and trailing bytes, with an Error naming the
// file.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace splitray {

struct DenseLayer {
  int in = 0, out = 0;
  int activation = 0;         // 0 = identity, 1 = relu
  std::vector<float> weight;  // out × in, row major
  std::vector<float> bias;    // out
};

struct LevelEncoder {
  std::vector<DenseLayer> point_layers;  // per point, shared across points and axes
  std::vector<DenseLayer> head_layers;   // after pooling; the last has out = 1
};

enum class NeuralCost { sah = 0, vvh = 1 };
enum class NeuralPooling { max = 0, mean = 1 };

struct NeuralModel {
  NeuralCost cost = NeuralCost::sah;
  int points = 2048;  // M: the sample size the model was trained with
  NeuralPooling pooling = NeuralPooling::max;
  std::vector<LevelEncoder> levels;  // levels.size() = the depth of the inferred top
  std::string metadata;              // JSON text

  int depth() const { return static_cast<int>(levels.size()); }
};

NeuralModel read_neural_model(const std::string& path);                      // throws Error
void write_neural_model(const NeuralModel& model, const std::string& path);  // atomic rename

// λ' of one axis at one level: `coords` are the M inputs already normalised (active points in
// [1, 2], masked points exactly 0). Returns the raw head output (unclamped).
// `scratch` avoids allocations across calls.
float encode_axis(const LevelEncoder& encoder, NeuralPooling pooling, std::span<const float> coords,
                  std::vector<float>& scratch);

// encode_axis over many inputs at once (all nodes and axes of one tree level share the
// level's encoder, so their points go through the per-point layers in one pass): input g is
// coords[offsets[g], offsets[g + 1]); out[g] receives exactly what encode_axis gives for it.
void encode_groups(const LevelEncoder& encoder, NeuralPooling pooling,
                   std::span<const float> coords, std::span<const std::size_t> offsets,
                   std::span<float> out, std::vector<float>& scratch);

}  // namespace splitray

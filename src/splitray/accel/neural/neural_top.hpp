#pragma once
// Greedy inference of a fixed-depth kd-tree top from a point sample (paper 003 §4.3).
//
// Per node, top-down and level by level: the samples inside the node's cell are the active
// points; on each axis their coordinates are normalised to the active points' tight bounds and
// shifted into [1, 2] and the level's encoder gives λ' (clamped to [0, 1]); the split on that
// axis lies at tight_lo + λ' (tight_hi - tight_lo) (Eq. 7/14: the tight-bounds offset mapped
// back to node, hence global, coordinates). The axis is chosen by the local cost of Eq. 4 (SAH
// of Eq. 5 or VVH of Eq. 6) evaluated on the samples, and the node stays a leaf when that is
// cheaper than every split. Sample counts are scaled to the full input (× N / M) so that the
// leaf-or-split decision is the one the full population would make.
//
// The result depends only on the model, the samples and the options: it runs on one thread
// (it takes about a millisecond), never on the thread count.
#include <cstdint>
#include <span>
#include <vector>

#include "splitray/accel/neural/neural_model.hpp"
#include "splitray/core/aabb.hpp"

namespace splitray {

struct NeuralTopNode {
  Aabb box;       // the node's cell
  int axis = -1;  // -1 = leaf
  float split = 0;
  std::int32_t child[2] = {-1, -1};  // below (coordinate < split), above
  std::uint32_t samples = 0;         // active samples in the cell
  bool leaf() const { return axis < 0; }
};

struct NeuralTopOptions {
  NeuralCost cost = NeuralCost::sah;
  float traversal_cost = 15;     // c_t (SAH: K_T; VVH: 1.2)
  float intersection_cost = 20;  // c_i (SAH: K_I; VVH: 1)
  float radius = 0;              // VVH: cells expanded by this radius
  double population = 0;         // N, the full input's size; <= 0: the sample count
  int max_depth = 0;  // levels to infer; 0 or more than the model has = the model's depth
  // Nodes holding fewer primitives than this (estimated: samples × population / M) are left
  // to the expansion builder, whose exact decisions beat sampled ones on small cells.
  double min_split_population = 0;
  // The top of greedy_top over the same samples (the model's depth) instead of the network's.
  bool greedy = false;
};

struct NeuralTop {
  std::vector<NeuralTopNode> nodes;  // level order from the root at 0; children after parents
  int depth = 0;                     // levels of splits actually made (0 = the root is a leaf)
  double inference_ms = 0;           // masking, normalisation, network and cost evaluation
  double inference_cpu_ms = 0;       // the same as CPU time of the (one) thread: robust to load
  std::size_t leaves() const;
};

// `samples` are the M points (fewer is fine, extra ones are used as well), `root` the cell of
// the root (the bounds of the whole input, which may exceed the samples' bounds).
NeuralTop infer_neural_top(const NeuralModel& model, std::span<const Vec3> samples,
                           const Aabb& root, const NeuralTopOptions& options);

// The baseline of the network (paper 003 Fig. 3's ablation, and what training compares
// against): a greedy SAH/VVH top of `options.max_depth` levels on the same samples, each split
// chosen by an exact sweep over the samples of the local cost of Eq. 4 that
// infer_neural_top uses to pick an axis; the same leaf rule (options.min_split_population).
NeuralTop greedy_top(std::span<const Vec3> samples, const Aabb& root,
                     const NeuralTopOptions& options);

// The pieces the inferred top shares with the greedy top, so that both are costed and built
// alike:
// the weight of a cell in Eq. 4: surface area (SAH, Eq. 5) or the volume of the cell grown by
// the search radius (VVH, Eq. 6); only ratios are used.
double neural_cell_measure(const Aabb& box, NeuralCost cost, float radius);
// N / M: sample counts scaled to the full input (1 without a population).
double neural_sample_scale(std::size_t samples, const NeuralTopOptions& options);
// Eq. 4 of cutting `box` (weight `parent`) at `split` on `axis` with `below` of `total` samples
// below the plane, counts scaled by `scale`.
double neural_split_cost(const Aabb& box, int axis, float split, std::size_t below,
                         std::size_t total, double parent, double scale,
                         const NeuralTopOptions& options);
// Makes node `n` interior at (axis, split) with two new child cells: `pts`, the node's active
// samples, are divided between them (coordinate < split below) into `active` (one list per
// node), and the children's indices are appended to `next`.
void split_neural_top_node(NeuralTop& top, std::size_t n, int axis, float split,
                           std::span<const std::uint32_t> pts, std::span<const Vec3> samples,
                           std::vector<std::vector<std::uint32_t>>& active,
                           std::vector<std::size_t>& next);

}  // namespace splitray

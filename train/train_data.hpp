#pragma once
// The training point sets of paper 003 §6.1: per training mesh a pool of area-weighted surface
// samples (the SAH input of inference; for the VVH they stand for the point cloud, as in the
// paper's 1M samples per scene), a shallow greedy tree over the pool, and from every node's
// cell M uniform draws of the pool points inside it, each set again under random rotations.
#include <cstdint>
#include <string>
#include <vector>

#include "splitray/accel/neural/neural_model.hpp"
#include "splitray/core/aabb.hpp"

namespace splitray::train {

struct TrainSet {
  std::vector<Vec3> points;  // the M samples
  Aabb root;                 // the cell they were drawn from (rotated: their tight bounds)
  double population = 0;     // primitives the cell stands for (inference's N)
  float radius = 0;          // VVH search radius for this set
  std::string source;        // mesh file and node, for reports
  int level = 0;             // the tree level of its cell: the first encoder it trains
};

struct DataOptions {
  NeuralCost cost = NeuralCost::sah;
  int points = 512;                // M per set
  int tree_depth = 3;              // levels of the shallow greedy tree whose nodes give the sets
  bool levels_from_nodes = false;  // set.level = the node's depth (lookahead training), else 0
  int rotations = 2;               // extra randomly rotated copies of every set
  std::size_t pool = 200000;       // surface samples per mesh
  double vvh_points = 1e6;         // the point cloud size a whole mesh stands for (VVH)
  float traversal_cost = 15, intersection_cost = 20;
  std::uint64_t seed = 1;
};

// Throws Error naming the file for unreadable or empty meshes.
std::vector<TrainSet> build_training_sets(const std::vector<std::string>& files,
                                          const DataOptions& options);

// Whole-mesh sets (root = the mesh bounds, as `--builder neural` sees it) for evaluation.
std::vector<TrainSet> whole_mesh_sets(const std::vector<std::string>& files,
                                      const DataOptions& options, int per_mesh);

}  // namespace splitray::train

#pragma once
// The interface every nearest-neighbour structure implements and its settings (the factory is
// neighbor_index.hpp), so that the peers (peers/) implement it without depending on the
// factory that makes them.
#include <memory>
#include <span>
#include <string>

#include "splitray/query/neighbors.hpp"
#include "splitray/query/point_tree.hpp"

namespace splitray {

struct NeighborIndexConfig {
  std::string builder = "vvh";  // vvh | sah | median | brute | nanoflann | flann
  int leaf_size = 10;           // all trees, ours and the peers'
  float radius = 0;             // VVH/SAH cell expansion; <= 0 automatic (see PointTreeConfig)
  // Batched peer queries in the given order (false, as their users call them) or in our
  // Morton order (true: shows how much of a difference is query order alone).
  bool coherent_peers = false;
  NeuralConfig neural{};  // builder "neural": see PointTreeConfig
};

class NeighborIndex {
 public:
  virtual ~NeighborIndex() = default;
  // Batched, over all cores; results in query order. k nearest: 1 <= k <= points.
  virtual KnnResult knn(std::span<const Vec3> queries, int k) const = 0;
  // Every point within distance r (distance² <= r * r), sorted by (distance, index).
  virtual RadiusResult radius(std::span<const Vec3> queries, float r) const = 0;

  const std::string& name() const { return name_; }
  double build_ms() const { return build_ms_; }
  std::size_t points() const { return points_; }
  // Our trees only (null for brute and the peers).
  virtual const PointTree* tree() const { return nullptr; }

 protected:
  std::string name_;
  double build_ms_ = 0;
  std::size_t points_ = 0;
};

}  // namespace splitray

#pragma once
// A kd-tree over points for exact k-nearest, radius and point-in-leaf queries (paper 003 §6.3).
// The tree references the caller's points (a span that must outlive it) and stores only a
// permutation of point indices and 16-byte nodes. Builders (one split chooser each, one
// shared O(n log n) builder over presorted arrays):
//   vvh    — greedy Voxel Volume Heuristic (Wald et al. 2004; paper 003 Eq. 4 + 6): every
//            distinct point coordinate on every axis is evaluated exactly, cell volumes are
//            expanded by the search radius;
//   sah    — the same sweep with cell surface areas (paper 003 Eq. 5);
//   median — the median of the longest axis (balanced).
// The tree depends only on the points and the config, never on the thread count.
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "splitray/core/aabb.hpp"
#include "splitray/query/neighbors.hpp"
#include "splitray/query/point_tree_config.hpp"

namespace splitray {

struct PointTreeStats {
  std::string builder;
  std::size_t points = 0;
  std::size_t nodes = 0;
  std::size_t leaves = 0;
  int max_depth = 0;
  double mean_leaf_depth = 0;
  double mean_leaf_points = 0;
  std::size_t bytes = 0;
  double build_ms = 0;
  float radius = 0;     // the VVH/SAH expansion used
  double vvh_cost = 0;  // paper 003 Eq. 4 + 6 evaluated on the finished tree (any builder)
  std::optional<double> inference_ms;  // builder neural: the greedy top inference
  int top_depth = 0;                   // builder neural: levels of the inferred top
};

class PointTree {
 public:
  static constexpr int kMaxDepth = kPointTreeMaxDepth;

  // Throws Error on no points, a NaN or infinite point, a bad config or an unknown builder.
  explicit PointTree(std::span<const Vec3> points, const PointTreeConfig& config = {});

  // The k nearest of one query, nearest first; k <= size(). Returns k.
  int knn(const Vec3& query, int k, std::span<std::uint32_t> indices,
          std::span<float> distances) const;
  // All points within distance r, sorted by (distance, index); appended to the vectors.
  void radius(const Vec3& query, float r, std::vector<std::uint32_t>& indices,
              std::vector<float>& distances) const;
  // Point-in-leaf: the points of the leaf whose cell holds the query (below < above_min);
  // none where that is an empty-space cut's empty leaf (builder neural, in empty space).
  std::span<const std::uint32_t> leaf_points(const Vec3& query) const;
  std::uint32_t leaf_node(const Vec3& query) const;

  // Batched over all cores; identical to the single-query calls for any thread count.
  // Queries are processed in a spatially coherent order (a Morton sort) for cache reuse.
  KnnResult knn(std::span<const Vec3> queries, int k) const;
  RadiusResult radius(std::span<const Vec3> queries, float r) const;
  std::vector<std::uint32_t> leaf_populations(std::span<const Vec3> queries) const;

  std::size_t size() const { return points_.size(); }
  std::span<const Vec3> points() const { return points_; }
  std::span<const PointNode> nodes() const { return nodes_; }
  std::span<const std::uint32_t> permutation() const { return permutation_; }
  const Aabb& bounds() const { return bounds_; }
  double build_ms() const { return build_ms_; }
  float expansion_radius() const { return radius_; }  // the VVH/SAH expansion used
  PointTreeStats stats() const;                       // walks the tree

  // Builders by name; the first is the default.
  static std::vector<std::string> builder_names();

 private:
  void knn_unchecked(const Vec3& query, int k, std::uint32_t* indices, float* distances) const;

  std::span<const Vec3> points_;
  std::vector<PointNode> nodes_;
  std::vector<std::uint32_t> permutation_;
  Aabb bounds_;
  PointTreeConfig config_;
  float radius_ = 0;
  double build_ms_ = 0;
  std::optional<double> inference_ms_;  // builder neural
  int top_depth_ = 0;
};

// Spatially coherent processing order of queries (Morton order in their bounding box);
// used by the batched searches of every structure that wants it.
std::vector<std::uint32_t> coherent_order(std::span<const Vec3> queries);

}  // namespace splitray

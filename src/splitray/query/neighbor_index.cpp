#include "splitray/query/neighbor_index.hpp"

#include <cmath>

#include "splitray/core/errors.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/query/brute_force.hpp"
#include "splitray/query/peers/peers.hpp"

namespace splitray {
namespace {

class TreeIndex final : public NeighborIndex {
 public:
  TreeIndex(std::span<const Vec3> points, const NeighborIndexConfig& config)
      : tree_(points, {.builder = config.builder,
                       .leaf_size = config.leaf_size,
                       .radius = config.radius,
                       .neural = config.neural}) {
    name_ = config.builder;
    build_ms_ = tree_.build_ms();
    points_ = points.size();
  }
  KnnResult knn(std::span<const Vec3> queries, int k) const override {
    return tree_.knn(queries, k);
  }
  RadiusResult radius(std::span<const Vec3> queries, float r) const override {
    return tree_.radius(queries, r);
  }
  const PointTree* tree() const override { return &tree_; }

 private:
  PointTree tree_;
};

class BruteIndex final : public NeighborIndex {
 public:
  explicit BruteIndex(std::span<const Vec3> points) : points_span_(points) {
    const Timer timer;
    check_points(points, "brute-force search");
    name_ = "brute";
    points_ = points.size();
    build_ms_ = timer.ms();
  }
  KnnResult knn(std::span<const Vec3> queries, int k) const override {
    return brute_force_knn(points_span_, queries, k);
  }
  RadiusResult radius(std::span<const Vec3> queries, float r) const override {
    return brute_force_radius(points_span_, queries, r);
  }

 private:
  std::span<const Vec3> points_span_;
};

}  // namespace

std::vector<std::string> neighbor_index_names() {
  return {"vvh", "sah", "median", "brute", "nanoflann", "flann"};
}

std::unique_ptr<NeighborIndex> make_neighbor_index(std::span<const Vec3> points,
                                                   const NeighborIndexConfig& config) {
  if (config.leaf_size < 1 || config.leaf_size > (1 << 20))
    throw Error("neighbour index", "leaf size " + std::to_string(config.leaf_size) +
                                       " is out of range (1 .. 1048576)");
  const std::string& b = config.builder;
  if (b == "vvh" || b == "sah" || b == "median" || b == "neural")
    return std::make_unique<TreeIndex>(points, config);
  if (b == "brute") return std::make_unique<BruteIndex>(points);
  if (b == "nanoflann") return detail::make_nanoflann_index(points, config);
  if (b == "flann") return detail::make_flann_index(points, config);
  throw Error(
      "neighbour index",
      "unknown builder '" + b + "' (expected vvh, sah, median, neural, brute, nanoflann or flann)");
}

namespace detail {

float strict_radius_squared(float r) {
  return std::nextafter(r * r, std::numeric_limits<float>::infinity());
}

}  // namespace detail
}  // namespace splitray

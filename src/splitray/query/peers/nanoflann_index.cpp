// nanoflann 1.4.3 (Debian): the 1.4 API, tree built in the constructor, squared distances.
#include <nanoflann.hpp>

#include "splitray/core/timer.hpp"
#include "splitray/query/batch.hpp"
#include "splitray/query/peers/peers.hpp"
#include "splitray/query/point_tree.hpp"

namespace splitray::detail {
namespace {

// nanoflann reads the caller's points through this adaptor: no copy, like our trees.
struct PointsAdaptor {
  std::span<const Vec3> points;
  std::size_t kdtree_get_point_count() const { return points.size(); }
  float kdtree_get_pt(std::uint32_t i, std::size_t dim) const {
    return points[i][static_cast<int>(dim)];
  }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, PointsAdaptor>,
                                                 PointsAdaptor, 3, std::uint32_t>;

class NanoflannIndex final : public NeighborIndex {
 public:
  NanoflannIndex(std::span<const Vec3> points, const NeighborIndexConfig& config)
      : adaptor_{points}, coherent_(config.coherent_peers) {
    check_points(points, "nanoflann");
    const Timer timer;
    tree_ = std::make_unique<Tree>(3, adaptor_,
                                   nanoflann::KDTreeSingleIndexAdaptorParams(config.leaf_size));
    build_ms_ = timer.ms();
    name_ = "nanoflann";
    points_ = points.size();
  }

  KnnResult knn(std::span<const Vec3> queries, int k) const override {
    check_k(k, points_, "k-nearest search");
    check_queries(queries, "k-nearest search");
    KnnResult result = make_knn_result(queries.size(), k);
    const std::size_t kk = static_cast<std::size_t>(k);
    for_each_query(queries, order(queries), [&](std::size_t q, const Vec3& query) {
      std::uint32_t* indices = result.indices.data() + q * kk;
      float* distances = result.distances.data() + q * kk;
      tree_->knnSearch(&query.x, kk, indices, distances);
      for (std::size_t j = 0; j < kk; ++j) distances[j] = std::sqrt(distances[j]);
    });
    return result;
  }

  RadiusResult radius(std::span<const Vec3> queries, float r) const override {
    check_radius(r, "radius search");
    check_queries(queries, "radius search");
    const float r2 = strict_radius_squared(r);
    return gather_radius(queries, order(queries), [&](std::size_t, const Vec3& query, auto& found) {
      thread_local std::vector<std::pair<std::uint32_t, float>> pairs;
      tree_->radiusSearch(&query.x, r2, pairs, nanoflann::SearchParams(32, 0, true));
      for (const auto& [i, d2] : pairs) found.emplace_back(d2, i);
    });
  }

 private:
  std::vector<std::uint32_t> order(std::span<const Vec3> queries) const {
    return coherent_ ? coherent_order(queries) : std::vector<std::uint32_t>{};
  }

  PointsAdaptor adaptor_;
  bool coherent_;
  std::unique_ptr<Tree> tree_;
};

}  // namespace

std::unique_ptr<NeighborIndex> make_nanoflann_index(std::span<const Vec3> points,
                                                    const NeighborIndexConfig& config) {
  return std::make_unique<NanoflannIndex>(points, config);
}

}  // namespace splitray::detail

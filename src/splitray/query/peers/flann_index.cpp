// FLANN 1.9.2 (Debian): its exact single kd-tree (KDTreeSingleIndex), default reordering
// (FLANN copies the points into leaf order, its own choice), squared L2 distances.
#include <flann/flann.hpp>

#include "splitray/core/timer.hpp"
#include "splitray/query/batch.hpp"
#include "splitray/query/peers/peers.hpp"
#include "splitray/query/point_tree.hpp"

namespace splitray::detail {
namespace {

using Tree = flann::KDTreeSingleIndex<flann::L2_Simple<float>>;

// FLANN's matrices take non-const pointers but only read the points and queries. (No member
// access through data() when the span is empty: it may be null.)
flann::Matrix<float> as_matrix(std::span<const Vec3> v) {
  return {v.empty() ? nullptr : const_cast<float*>(&v.front().x), v.size(), 3, sizeof(Vec3)};
}

class FlannIndex final : public NeighborIndex {
 public:
  FlannIndex(std::span<const Vec3> points, const NeighborIndexConfig& config)
      : coherent_(config.coherent_peers) {
    check_points(points, "FLANN");
    const Timer timer;
    tree_ =
        std::make_unique<Tree>(as_matrix(points), flann::KDTreeSingleIndexParams(config.leaf_size));
    tree_->buildIndex();
    build_ms_ = timer.ms();
    name_ = "flann";
    points_ = points.size();
  }

  KnnResult knn(std::span<const Vec3> queries, int k) const override {
    check_k(k, points_, "k-nearest search");
    check_queries(queries, "k-nearest search");
    KnnResult result = make_knn_result(queries.size(), k);
    const std::size_t kk = static_cast<std::size_t>(k);
    const std::vector<std::uint32_t> ord = order(queries);
    // FLANN's own batched call on each chunk (one core each; the chunks spread the cores).
    parallel_chunks(queries.size(), kQueryChunk, [&](std::size_t b, std::size_t e) {
      const std::size_t rows = e - b;
      const std::vector<Vec3> chunk = gather(queries, ord, b, e);
      std::vector<std::size_t> indices(rows * kk);
      std::vector<float> dists(rows * kk);
      flann::Matrix<std::size_t> index_matrix(indices.data(), rows, kk);
      flann::Matrix<float> dist_matrix(dists.data(), rows, kk);
      tree_->knnSearch(as_matrix(chunk), index_matrix, dist_matrix, kk, flann::SearchParams(-1));
      for (std::size_t j = b; j < e; ++j) {
        const std::size_t q = ord.empty() ? j : ord[j];
        for (std::size_t m = 0; m < kk; ++m) {
          result.indices[q * kk + m] = static_cast<std::uint32_t>(indices[(j - b) * kk + m]);
          result.distances[q * kk + m] = std::sqrt(dists[(j - b) * kk + m]);
        }
      }
    });
    return result;
  }

  RadiusResult radius(std::span<const Vec3> queries, float r) const override {
    check_radius(r, "radius search");
    check_queries(queries, "radius search");
    const float r2 = strict_radius_squared(r);
    const std::vector<std::uint32_t> ord = order(queries);
    return gather_radius_chunks(
        queries.size(), ord, [&](std::size_t b, std::size_t e, const auto& emit) {
          const std::vector<Vec3> chunk = gather(queries, ord, b, e);
          std::vector<std::vector<std::size_t>> indices;
          std::vector<std::vector<float>> dists;
          tree_->radiusSearch(as_matrix(chunk), indices, dists, r2, flann::SearchParams(-1));
          std::vector<WithinRadius::Entry> found;
          for (std::size_t row = 0; row < e - b; ++row) {
            found.clear();
            for (std::size_t m = 0; m < indices[row].size(); ++m)
              found.emplace_back(dists[row][m], static_cast<std::uint32_t>(indices[row][m]));
            emit(found);
          }
        });
  }

 private:
  std::vector<std::uint32_t> order(std::span<const Vec3> queries) const {
    return coherent_ ? coherent_order(queries) : std::vector<std::uint32_t>{};
  }
  // The queries at positions [b, e) of the processing order, as FLANN rows.
  static std::vector<Vec3> gather(std::span<const Vec3> queries,
                                  const std::vector<std::uint32_t>& ord, std::size_t b,
                                  std::size_t e) {
    std::vector<Vec3> rows(e - b);
    for (std::size_t j = b; j < e; ++j) rows[j - b] = queries[ord.empty() ? j : ord[j]];
    return rows;
  }

  bool coherent_;
  std::unique_ptr<Tree> tree_;
};

}  // namespace

std::unique_ptr<NeighborIndex> make_flann_index(std::span<const Vec3> points,
                                                const NeighborIndexConfig& config) {
  return std::make_unique<FlannIndex>(points, config);
}

}  // namespace splitray::detail

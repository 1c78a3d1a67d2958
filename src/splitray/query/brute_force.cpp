#include "splitray/query/brute_force.hpp"

#include "splitray/query/batch.hpp"

namespace splitray {

KnnResult brute_force_knn(std::span<const Vec3> points, std::span<const Vec3> queries, int k) {
  check_points(points, "brute-force search");
  check_k(k, points.size(), "k-nearest search");
  check_queries(queries, "k-nearest search");
  KnnResult result = detail::make_knn_result(queries.size(), k);
  const std::size_t kk = static_cast<std::size_t>(k);
  detail::for_each_query(queries, {}, [&](std::size_t q, const Vec3& query) {
    detail::nearest_k(
        k, result.indices.data() + q * kk, result.distances.data() + q * kk, [&](auto& set) {
          for (std::size_t i = 0; i < points.size(); ++i)
            set.offer(distance_squared(points[i], query), static_cast<std::uint32_t>(i));
        });
  });
  return result;
}

RadiusResult brute_force_radius(std::span<const Vec3> points, std::span<const Vec3> queries,
                                float r) {
  check_points(points, "brute-force search");
  check_radius(r, "radius search");
  check_queries(queries, "radius search");
  const float r2 = r * r;
  return detail::gather_radius(queries, {}, [&](std::size_t, const Vec3& query, auto& found) {
    detail::WithinRadius within{r2, &found};
    for (std::size_t i = 0; i < points.size(); ++i)
      within.offer(distance_squared(points[i], query), static_cast<std::uint32_t>(i));
  });
}

}  // namespace splitray

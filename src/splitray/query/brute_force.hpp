#pragma once
// The oracle: every query checks every point, in index order, with the result sets the tree
// uses. Answers follow neighbors.hpp exactly (ties to the smaller index).
#include <span>

#include "splitray/query/neighbors.hpp"

namespace splitray {

KnnResult brute_force_knn(std::span<const Vec3> points, std::span<const Vec3> queries, int k);
RadiusResult brute_force_radius(std::span<const Vec3> points, std::span<const Vec3> queries,
                                float r);

}  // namespace splitray

#pragma once
// The standard inputs of `splitray knn` and `splitray bench knn`: points from a point file, or
// area-weighted samples of a mesh surface; queries reproducible from a seed.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "splitray/core/mesh.hpp"

namespace splitray {

struct PointInput {
  std::string path;
  std::optional<Mesh> mesh;  // set when the points are surface samples
  std::vector<Vec3> points;
};

// A point file (see is_point_file) is read as is; any other file is loaded as a mesh
// (load_mesh) and sampled with `samples` area-weighted points from (seed, kPointStream).
PointInput load_point_input(const std::string& path, std::size_t samples, std::uint64_t seed);

// Queries from (seed, kQueryStream): surface samples of the mesh, or for a point file, input
// points picked at random and moved by up to 1e-3 of the bounding-box diagonal per axis.
std::vector<Vec3> make_queries(const PointInput& input, std::size_t count, std::uint64_t seed);

}  // namespace splitray

#pragma once
// Area-weighted uniform samples on a mesh surface (paper 003 §6.1: the point sets of its
// nearest-neighbour experiments). Reproducible from (seed, stream) for any thread count.
#include <cstdint>
#include <vector>

#include "splitray/core/mesh.hpp"

namespace splitray {

// Streams of the standard inputs: the points and the queries of one seed never coincide.
inline constexpr std::uint64_t kPointStream = 1;
inline constexpr std::uint64_t kQueryStream = 2;

// Throws Error if the mesh has no triangle of positive area.
std::vector<Vec3> sample_surface(const Mesh& mesh, std::size_t count, std::uint64_t seed,
                                 std::uint64_t stream = kPointStream);

}  // namespace splitray

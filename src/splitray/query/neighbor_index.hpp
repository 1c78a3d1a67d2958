#pragma once
// One interface for every nearest-neighbour structure, so the CLI, tests and benchmarks swap
// them by name: our point kd-trees (vvh, sah, median), the brute-force oracle, and the
// libraries people use instead (nanoflann, FLANN: measured in the same process as yardsticks).
// Every structure references the caller's points, which must outlive it.
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "splitray/query/neighbor_index_interface.hpp"

namespace splitray {

// Throws Error on an unknown name, no points, a NaN/infinite point or a bad config.
std::unique_ptr<NeighborIndex> make_neighbor_index(std::span<const Vec3> points,
                                                   const NeighborIndexConfig& config = {});
std::vector<std::string> neighbor_index_names();  // first = default

}  // namespace splitray

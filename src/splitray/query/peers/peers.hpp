#pragma once
// nanoflann 1.4 and FLANN 1.9 (Debian) behind NeighborIndex (internal). Both get the same
// leaf size as our trees; their squared, strict (< r²) radius convention is mapped to ours
// (distance² <= r², float) by passing the next float above r².
#include <memory>

#include "splitray/query/neighbor_index_interface.hpp"

namespace splitray::detail {

std::unique_ptr<NeighborIndex> make_nanoflann_index(std::span<const Vec3> points,
                                                    const NeighborIndexConfig& config);
std::unique_ptr<NeighborIndex> make_flann_index(std::span<const Vec3> points,
                                                const NeighborIndexConfig& config);

// The squared radius to hand a library that keeps distance² < r2.
float strict_radius_squared(float r);

}  // namespace splitray::detail

#pragma once
// Triangulation of one polygon by ear clipping in the plane that fits it best (Newell's
// normal). assimp 5.2's aiProcess_Triangulate returns overlapping triangles for some concave
// polygons (assimp issues #1136, #3019; fixed only in 2025), so splitray does it itself.
#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "splitray/core/vec.hpp"

namespace splitray {

// Appends exactly corners.size() - 2 triangles of local corner indices (0 .. n-1), in the
// polygon's winding. A simple polygon (convex or not) is covered exactly; for convex polygons
// the result is the fan from corner 0. A polygon that is not simple, or is degenerate, still
// yields n - 2 triangles (clipped where no proper ear exists). Returns the work done (corner
// tests), so that callers can bound the time hostile polygons take.
std::uint64_t triangulate_polygon(std::span<const Vec3> corners,
                                  std::vector<std::array<std::uint32_t, 3>>& out);

}  // namespace splitray

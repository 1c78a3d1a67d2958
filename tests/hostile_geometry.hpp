#pragma once
// Generated geometry that is hostile to spatial hierarchies (issue #19): a real architectural
// model once made every kd builder lose triangles a few ulps thick. Each mesh mixes, at one
// scale and offset (from 2^-12 to 2^16, some far from the origin):
// - nearly axis-aligned triangles whose thin axis spans 0-8 ulps;
// - tessellated walls and floors (shared vertices) that straddle many cells, their vertices
//   moved off the plane by 0-3 ulps;
// - triangles exactly in a few shared planes, and others a few ulps beside them or crossing
//   them with a vertex exactly on them;
// - slivers (needles, nearly collinear vertices);
// - duplicated and coplanar overlapping triangles (the tie rule decides between them);
// - degenerate triangles (collinear, repeated or identical vertices).
// Many small meshes rather than one large one: each is cheap to build and to check by brute
// force, and together they cover many scales, offsets and arrangements.
#include <cstdint>
#include <string>
#include <vector>

#include "splitray/core/triangle.hpp"

namespace splitray::test {

struct HostileMesh {
  std::string name;  // seed, scale and offset, for failure messages
  std::vector<Triangle> tris;
};

// Mesh `index` of the family drawn from `seed`; the same for the same arguments everywhere.
HostileMesh hostile_mesh(std::uint64_t seed, int index);

}  // namespace splitray::test

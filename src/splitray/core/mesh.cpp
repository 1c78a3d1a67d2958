#include "splitray/core/mesh.hpp"

#include "splitray/core/coordinates.hpp"
#include "splitray/core/errors.hpp"

namespace splitray {

Aabb Mesh::bounds() const {
  Aabb b;
  for (const Vec3& p : positions) b.extend(p);
  return b;
}

std::vector<Triangle> Mesh::triangles() const {
  std::vector<Triangle> out;
  out.reserve(faces.size());
  for (std::size_t f = 0; f < faces.size(); ++f) out.push_back(triangle(f));
  return out;
}

void Mesh::validate(const std::string& where) const {
  if (faces.empty()) throw Error(where, "the mesh has no triangles");
  for (std::size_t i = 0; i < positions.size(); ++i)
    if (!within_coordinate_limit(positions[i]))
      throw Error(where,
                  "vertex " + std::to_string(i) + " has " + coordinate_problem(positions[i]));
  for (std::size_t f = 0; f < faces.size(); ++f)
    for (std::uint32_t index : faces[f])
      if (index >= positions.size())
        throw Error(where, "face " + std::to_string(f) + " refers to vertex " +
                               std::to_string(index) + " but there are only " +
                               std::to_string(positions.size()));
  if (!normals.empty() && normals.size() != positions.size())
    throw Error(where, "normal count differs from vertex count");
  if (!uvs.empty() && uvs.size() != positions.size())
    throw Error(where, "texture coordinate count differs from vertex count");
  if (face_materials.size() != (materials.empty() ? 0 : faces.size()))
    throw Error(where, "per-face material count differs from the face count");
  for (std::size_t f = 0; f < face_materials.size(); ++f)
    if (face_materials[f] >= materials.size())
      throw Error(where, "face " + std::to_string(f) + " names material " +
                             std::to_string(face_materials[f]) + " of " +
                             std::to_string(materials.size()));
}

void Mesh::compute_vertex_normals() {
  normals.assign(positions.size(), Vec3{});
  for (std::size_t f = 0; f < faces.size(); ++f) {
    const Vec3 n = triangle(f).geometric_normal();  // length = 2 * area: area weighting
    for (std::uint32_t index : faces[f]) normals[index] += n;
  }
  for (Vec3& n : normals) n = normalize(n);
}

}  // namespace splitray

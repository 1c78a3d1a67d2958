#pragma once
// Indexed triangle meshes and the triangle soups hierarchies are built on.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "splitray/core/material.hpp"
#include "splitray/core/texture.hpp"
#include "splitray/core/triangle.hpp"

namespace splitray {

struct Mesh {
  std::string name;
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;  // per vertex, empty or positions.size(); shading only
  std::vector<std::array<std::uint32_t, 3>> faces;
  std::vector<Vec2> uvs;  // per vertex, empty or positions.size(); texture coordinates
  // The file's own materials and each face's index into them; both empty when the file has
  // none (the scene's default material is used).
  std::vector<Material> materials;
  std::vector<std::uint32_t> face_materials;

  std::size_t triangle_count() const { return faces.size(); }
  Triangle triangle(std::size_t f) const {
    const auto& i = faces[f];
    return {positions[i[0]], positions[i[1]], positions[i[2]]};
  }
  Aabb bounds() const;
  std::vector<Triangle> triangles() const;
  // Throws Error(where, ...) on out-of-range indices, non-finite coordinates, no faces, or
  // per-vertex and per-face arrays of the wrong size.
  void validate(const std::string& where) const;
  // Area-weighted per-vertex normals (used when a file has none).
  void compute_vertex_normals();
};

}  // namespace splitray

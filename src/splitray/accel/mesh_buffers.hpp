#pragma once
// An indexed triangle mesh in the caller's memory, described as Embree describes shared
// buffers: float32 vertex positions and uint32 vertex indices, each with a byte stride
// (12 when packed; larger when positions or indices are interleaved with other data).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/core/triangle.hpp"

namespace splitray {

struct MeshBuffers {
  const void* vertices =
      nullptr;  // vertex i's x, y, z: three floats at vertices + i * vertex_stride
  std::size_t vertex_count = 0;
  std::size_t vertex_stride = 3 * sizeof(float);
  const void* indices =
      nullptr;  // triangle j's vertices: three uint32 at indices + j * index_stride
  std::size_t triangle_count = 0;
  std::size_t index_stride = 3 * sizeof(std::uint32_t);

  Vec3 vertex(std::size_t i) const;
  const std::uint32_t* triangle_indices(std::size_t j) const;
  Triangle triangle(std::size_t j) const;

  // Throws Error(where, ...) on null buffers, strides smaller than an element, no
  // triangles, an index out of range or a non-finite coordinate of a used vertex.
  void validate(const std::string& where) const;
  // The triangle soup of the mesh (in parallel), as make_accel and refit take it.
  std::vector<Triangle> triangles() const;
};

// make_accel over caller buffers: validates them (Error naming `where`), then builds the
// structure, which keeps its own copy of the triangles in its own layout and no reference to
// the buffers: they may change or be freed as soon as this returns.
std::unique_ptr<Accel> make_accel(const std::string& name, const MeshBuffers& mesh,
                                  const BuildConfig& config = {},
                                  const std::string& where = "mesh buffers");

}  // namespace splitray

#include "splitray/accel/mesh_buffers.hpp"

#include <cmath>
#include <cstring>

#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

Vec3 MeshBuffers::vertex(std::size_t i) const {
  float p[3];  // memcpy: a stride need not keep the floats aligned
  std::memcpy(p, static_cast<const char*>(vertices) + i * vertex_stride, sizeof p);
  return {p[0], p[1], p[2]};
}

const std::uint32_t* MeshBuffers::triangle_indices(std::size_t j) const {
  return reinterpret_cast<const std::uint32_t*>(static_cast<const char*>(indices) +
                                                j * index_stride);
}

Triangle MeshBuffers::triangle(std::size_t j) const {
  std::uint32_t f[3];
  std::memcpy(f, triangle_indices(j), sizeof f);
  return {vertex(f[0]), vertex(f[1]), vertex(f[2])};
}

void MeshBuffers::validate(const std::string& where) const {
  if (triangle_count == 0) throw Error(where, "no triangles");
  if (!vertices || !indices) throw Error(where, "null vertex or index buffer");
  if (vertex_stride < 3 * sizeof(float) || index_stride < 3 * sizeof(std::uint32_t))
    throw Error(where, "vertex stride " + std::to_string(vertex_stride) + " or index stride " +
                           std::to_string(index_stride) +
                           " is smaller than one element (12 bytes)");
  for (std::size_t j = 0; j < triangle_count; ++j) {
    std::uint32_t f[3];
    std::memcpy(f, triangle_indices(j), sizeof f);
    for (int c = 0; c < 3; ++c) {
      if (f[c] >= vertex_count)
        throw Error(where, "vertex index " + std::to_string(f[c]) + " of triangle " +
                               std::to_string(j) + " is out of range (" +
                               std::to_string(vertex_count) + " vertices)");
      const Vec3 p = vertex(f[c]);
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        throw Error(where, "vertex " + std::to_string(f[c]) + " of triangle " + std::to_string(j) +
                               " has a non-finite coordinate");
    }
  }
}

std::vector<Triangle> MeshBuffers::triangles() const {
  std::vector<Triangle> tris(triangle_count);
  parallel_chunks(triangle_count, 4096, [&](std::size_t b, std::size_t e) {
    for (std::size_t j = b; j < e; ++j) tris[j] = triangle(j);
  });
  return tris;
}

std::unique_ptr<Accel> make_accel(const std::string& name, const MeshBuffers& mesh,
                                  const BuildConfig& config, const std::string& where) {
  mesh.validate(where);
  return make_accel(name, mesh.triangles(), config);
}

}  // namespace splitray

// MD2: assimp clamps an out-of-range triangle vertex index to the last vertex (with only a log
// message); this check reads the triangle list and rejects such files.
#include <cstring>
#include <string>

#include "splitray/core/errors.hpp"
#include "splitray/io/format_checks.hpp"

namespace splitray {
namespace {

std::int32_t read_i32(std::span<const unsigned char> b, std::size_t offset) {
  std::uint32_t u = std::uint32_t(b[offset]) | std::uint32_t(b[offset + 1]) << 8 |
                    std::uint32_t(b[offset + 2]) << 16 | std::uint32_t(b[offset + 3]) << 24;
  std::int32_t v;
  std::memcpy(&v, &u, 4);
  return v;
}

}  // namespace

std::size_t check_md2(std::span<const unsigned char> bytes, const std::string& where) {
  if (bytes.size() < 68) throw Error(where, "too small for an MD2 file (truncated?)");
  if (std::memcmp(bytes.data(), "IDP2", 4) != 0)
    throw Error(where, "not an MD2 file (no IDP2 signature)");
  const std::int32_t vertices = read_i32(bytes, 24), triangles = read_i32(bytes, 32);
  const std::int32_t tris_offset = read_i32(bytes, 52);
  if (vertices <= 0 || triangles < 0 || tris_offset < 0)
    throw Error(where, "the MD2 header has negative or zero counts");
  if (std::uint64_t(tris_offset) + 12 * std::uint64_t(triangles) > bytes.size())
    throw Error(where, "truncated: the MD2 header declares " + std::to_string(triangles) +
                           " triangles that do not fit in the file");
  for (std::int32_t t = 0; t < triangles; ++t) {
    const std::size_t at = std::size_t(tris_offset) + 12 * std::size_t(t);
    for (int k = 0; k < 3; ++k) {
      const unsigned index = unsigned(bytes[at + 2 * k]) | unsigned(bytes[at + 2 * k + 1]) << 8;
      if (index >= unsigned(vertices))
        throw Error(where, "MD2 triangle " + std::to_string(t) + " refers to vertex " +
                               std::to_string(index) + " but frames have only " +
                               std::to_string(vertices) + " vertices (index out of range)");
    }
  }
  return std::size_t(triangles);
}

}  // namespace splitray

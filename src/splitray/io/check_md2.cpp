// MD2: the whole layout checked before assimp reads it. assimp clamps an out-of-range triangle
// vertex index to the last vertex (with only a log message) and reads sections through header
// counts and offsets it does not all check (fuzz_md2 found crashes in it), so every count,
// section and index is checked here against the file.
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
  const auto field = [&](int k) { return read_i32(bytes, 4 * std::size_t(k)); };
  if (field(1) != 8)
    throw Error(where, "MD2 version " + std::to_string(field(1)) + " (only version 8 exists)");
  const std::int32_t skin_width = field(2), skin_height = field(3), frame_size = field(4);
  const std::int32_t skins = field(5), vertices = field(6), uvs = field(7), triangles = field(8),
                     commands = field(9), frames = field(10);
  // assimp reads every section below through these counts and offsets without checking all of
  // them against the file (a UV index with no UVs, a frame smaller than its vertices crash it).
  const struct {
    const char* name;
    std::int32_t count, most;
  } counts[] = {{"skins", skins, 1 << 10},
                {"vertices", vertices, 1 << 16},
                {"texture coordinates", uvs, 1 << 20},
                {"triangles", triangles, 1 << 20},
                {"GL commands", commands, 1 << 24},
                {"frames", frames, 1 << 16}};
  for (const auto& c : counts)
    if (c.count < 0 || c.count > c.most)
      throw Error(where, "the MD2 header declares " + std::to_string(c.count) + " " + c.name +
                             " (0 to " + std::to_string(c.most) + " allowed)");
  if (vertices == 0 || triangles == 0 || frames == 0)
    throw Error(where, "the MD2 header declares no vertices, triangles or frames");
  if (uvs > 0 && (skin_width <= 0 || skin_height <= 0))
    throw Error(where, "the MD2 skin is " + std::to_string(skin_width) + " x " +
                           std::to_string(skin_height) +
                           " pixels (texture coordinates need a size)");
  if (std::int64_t(frame_size) < 40 + 4 * std::int64_t(vertices))
    throw Error(where, "MD2 frames of " + std::to_string(frame_size) + " bytes cannot hold " +
                           std::to_string(vertices) + " vertices");
  const struct {
    const char* name;
    std::int32_t offset;
    std::int64_t bytes;
  } sections[] = {{"skins", field(11), 64 * std::int64_t(skins)},
                  {"texture coordinates", field(12), 4 * std::int64_t(uvs)},
                  {"triangles", field(13), 12 * std::int64_t(triangles)},
                  {"frames", field(14), std::int64_t(frame_size) * frames},
                  {"GL commands", field(15), 4 * std::int64_t(commands)},
                  {"end", field(16), 0}};
  for (const auto& section : sections)
    if (section.offset < 0 ||
        std::int64_t(section.offset) + section.bytes > std::int64_t(bytes.size()))
      throw Error(where, std::string("truncated: the MD2 ") + section.name +
                             " lie beyond the end of the file (offset " +
                             std::to_string(section.offset) + ", " + std::to_string(section.bytes) +
                             " bytes, file " + std::to_string(bytes.size()) + " bytes)");
  const std::size_t tris_offset = std::size_t(field(13));
  for (std::int32_t t = 0; t < triangles; ++t) {
    const std::size_t at = tris_offset + 12 * std::size_t(t);
    for (int k = 0; k < 6; ++k) {
      const unsigned index = unsigned(bytes[at + 2 * k]) | unsigned(bytes[at + 2 * k + 1]) << 8;
      const bool uv = k >= 3;
      if (uv && uvs == 0) continue;  // no texture coordinates: the UV indices are not read
      if (index >= unsigned(uv ? uvs : vertices))
        throw Error(where, "MD2 triangle " + std::to_string(t) + " refers to " +
                               (uv ? "texture coordinate " : "vertex ") + std::to_string(index) +
                               " but there are only " + std::to_string(uv ? uvs : vertices) +
                               " (index out of range)");
    }
  }
  return std::size_t(triangles);
}

}  // namespace splitray

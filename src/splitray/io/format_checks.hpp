#pragma once
// Checks of the formats whose files carry counts and vertex indices (OBJ, PLY, STL, OFF, MD2,
// glTF). For some of these assimp clamps or drops bad indices, reads past short data or stops
// early without an error; each check reads the file itself, throws Error(where, problem) for
// anything malformed, and returns how many triangles the file describes so that the loader
// can reject a mesh that assimp silently changed.
#include <cstddef>
#include <optional>
#include <span>
#include <string>

namespace splitray {

std::size_t check_obj(std::span<const unsigned char> bytes, const std::string& where);
std::size_t check_ply(std::span<const unsigned char> bytes, const std::string& where);
std::size_t check_stl(std::span<const unsigned char> bytes, const std::string& where);
std::size_t check_off(std::span<const unsigned char> bytes, const std::string& where);
std::size_t check_md2(std::span<const unsigned char> bytes, const std::string& where);
// Nothing when the file is too broken to count (assimp then reports the problem).
std::optional<std::size_t> check_gltf(std::span<const unsigned char> bytes,
                                      const std::string& where);
// Rejects what makes assimp's COLLADA reader loop, overallocate or recurse; counts nothing.
void check_dae(std::span<const unsigned char> bytes, const std::string& where);

// The format a file's content shows by its signature (io/detect_format.cpp): "gzip", "glb",
// "gltf" (a JSON object), "ply", "md2", "stl" (ASCII 'solid' or the binary size), "dae",
// "off" (its header keyword); "" for content without one (OBJ, OFF without a keyword, ...).
std::string detect_mesh_format(std::span<const unsigned char> bytes);
// "PLY (.ply)", for messages.
std::string format_name(const std::string& format);
// Error(where, ...) naming both formats when the content shows a format other than the
// extension's (gltf and glb are one family), or when a .gltf/.glb file shows no glTF at all.
void check_content_matches_name(std::span<const unsigned char> bytes, const std::string& extension,
                                const std::string& where);

// The check for `extension` (lower case, no dot), or nothing for formats without one; first
// check_content_matches_name, so that the name cannot pick weaker checks than the content's.
std::optional<std::size_t> check_mesh_format(std::span<const unsigned char> bytes,
                                             const std::string& extension,
                                             const std::string& where);

}  // namespace splitray

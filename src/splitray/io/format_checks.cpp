#include "splitray/io/format_checks.hpp"

namespace splitray {

std::optional<std::size_t> check_mesh_format(std::span<const unsigned char> bytes,
                                             const std::string& extension,
                                             const std::string& where) {
  check_content_matches_name(bytes, extension, where);
  if (extension == "obj") return check_obj(bytes, where);
  if (extension == "ply") return check_ply(bytes, where);
  if (extension == "stl") return check_stl(bytes, where);
  if (extension == "off") return check_off(bytes, where);
  if (extension == "md2") return check_md2(bytes, where);
  if (extension == "gltf" || extension == "glb") return check_gltf(bytes, where);
  if (extension == "dae") check_dae(bytes, where);
  return std::nullopt;
}

}  // namespace splitray

#include "splitray/io/load_scene.hpp"

#include <vector>

#include "splitray/io/aff.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/io/read_file.hpp"
#include "splitray/io/scene_json.hpp"

namespace splitray {

Scene load_scene(const std::string& path) {
  const std::string extension = inner_extension(path);
  if (extension == "json") return load_json_scene(path);
  if (extension == "aff") return load_aff_scene(path);
  std::vector<std::string> warnings;
  Scene scene = scene_from_mesh(load_mesh(path, {.materials = true, .warnings = &warnings}));
  scene.warnings = std::move(warnings);
  return scene;
}

}  // namespace splitray

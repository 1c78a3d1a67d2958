#pragma once
// The JSON scene format (docs/scene-format.md): mesh files placed as instances with
// transforms and materials, lights, camera, background and ambient light. Strict: unknown
// keys, wrong types, missing required keys and out-of-range values are errors that name
// the key.
#include <string>

#include "splitray/core/scene.hpp"

namespace splitray {

Scene load_json_scene(const std::string& path);

}  // namespace splitray

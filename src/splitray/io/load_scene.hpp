#pragma once
// The one entry point for scene files of every kind (render, view, trace and the benchmarks):
// dispatches on the extension to the JSON scene reader, the BART reader or the mesh loader.
#include <string>

#include "splitray/core/scene.hpp"

namespace splitray {

// A JSON scene file (*.json: meshes, transforms, materials, lights, camera; see README), a
// BART scene (*.aff: its camera, lights and materials at the animation's start), or any mesh
// file, which becomes scene_from_mesh(load_mesh(path)) with the file's own materials.
// Problems that do not stop the load are in Scene::warnings.
Scene load_scene(const std::string& path);

}  // namespace splitray

#pragma once
// Mesh and scene loading. Every problem is an Error that names the file and the problem.
#include <string>

#include "splitray/core/mesh.hpp"
#include "splitray/core/scene.hpp"

namespace splitray {

// Loads every mesh of a file into one (node transforms applied; quads and polygons
// triangulated) through assimp: OBJ, PLY, STL, OFF, glTF/GLB, COLLADA, MD2 and the rest of
// assimp's formats. A name ending in .gz is gunzipped in memory first (zlib).
Mesh load_mesh(const std::string& path);

// A JSON scene file (*.json: meshes, transforms, materials, lights, camera; see README) or
// any mesh file, which becomes scene_from_mesh(load_mesh(path)).
Scene load_scene(const std::string& path);

}  // namespace splitray

#pragma once
// Mesh and scene loading. Every problem is an Error that names the file and the problem.
#include <string>
#include <vector>

#include "splitray/core/errors.hpp"  // the Error every loader throws
#include "splitray/core/mesh.hpp"

namespace splitray {

struct MeshLoadOptions {
  // Also the file's materials, texture coordinates and textures (io/materials.hpp), for
  // rendering; geometry alone otherwise.
  bool materials = false;
  // Where problems that do not stop the load go (a missing texture); null: dropped.
  std::vector<std::string>* warnings = nullptr;
  // Files the model references (glTF buffers, OBJ material libraries, COLLADA images,
  // textures) are read only inside this folder; empty: the model's own folder. A reference
  // outside (a buffer URI ../../etc/passwd from a stranger's model) is an Error naming it; a
  // texture outside is a warning and not read, as a missing texture. Set a wider
  // folder (even "/") for models whose files are spread over several folders.
  std::string references_root = {};
};

// Loads every mesh of a file into one (node transforms applied; quads and polygons
// triangulated) through assimp: OBJ, PLY, STL, OFF, glTF/GLB, COLLADA, MD2 and the rest of
// assimp's formats. A name ending in .gz is gunzipped in memory first (zlib).
Mesh load_mesh(const std::string& path, const MeshLoadOptions& options = {});

}  // namespace splitray

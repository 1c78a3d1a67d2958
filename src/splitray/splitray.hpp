#pragma once
// The public API of splitray in one header: include this, link splitray::splitray_render (or
// `pkg-config --cflags --libs splitray`), and everything below is yours. Each header it
// includes documents its part; the README's "Using splitray as a library" is the tour.
//
// Geometry and rays
#include "splitray/core/coordinates.hpp"    // the exact domain of vertices and rays
#include "splitray/core/errors.hpp"         // splitray::Error, thrown by everything below
#include "splitray/core/memory_budget.hpp"  // the budget inputs and counts are checked against
#include "splitray/core/mesh.hpp"           // indexed meshes
#include "splitray/core/ray.hpp"            // Ray, Hit and the tie rule
#include "splitray/core/scene.hpp"          // instances, materials, lights, camera
#include "splitray/core/triangle.hpp"       // triangles and the watertight test
// Hierarchies (DESIGN §2): kd, bih, bvh, embree, brute by name; from triangles or from your
// own strided vertex and index buffers
#include "splitray/accel/accel.hpp"
#include "splitray/accel/mesh_buffers.hpp"
#include "splitray/accel/mesh_scene.hpp"
// Files
#include "splitray/io/frames.hpp"       // animation sequences
#include "splitray/io/load_scene.hpp"   // JSON and BART scenes, or any mesh file as a scene
#include "splitray/io/mesh_io.hpp"      // OBJ, PLY, STL, OFF, glTF/GLB, DAE, MD2 (also .gz)
#include "splitray/io/scene_json.hpp"   // JSON scenes
#include "splitray/query/point_io.hpp"  // point files
// Nearest neighbours
#include "splitray/query/neighbor_index.hpp"
// Rendering
#include "splitray/core/camera.hpp"
#include "splitray/core/image.hpp"
#include "splitray/render/whitted.hpp"

#pragma once
// The parts of the module splitray._core, each binding one part of the library.
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>  // std::vector<std::string> of the *_names functions

namespace splitray::python {

void bind_scene(pybind11::module_& m);   // Scene: rays against a triangle mesh (scene.cpp)
void bind_kdtree(pybind11::module_& m);  // KDTree: nearest neighbours of points (kdtree.cpp)
void bind_io(pybind11::module_& m);      // load_mesh, load_points (io.cpp)

}  // namespace splitray::python

// splitray.load_mesh and splitray.load_points: the library's loaders (every format the CLI
// reads, .gz included) returning NumPy arrays.
#include <pybind11/numpy.h>

#include <cstring>
#include <string>

#include "bindings.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/query/point_io.hpp"

namespace splitray::python {

namespace py = pybind11;

namespace {

py::array_t<float> vec3_array(const std::vector<Vec3>& v) {
  py::array_t<float> out({static_cast<py::ssize_t>(v.size()), py::ssize_t{3}});
  if (!v.empty()) std::memcpy(out.mutable_data(), v.data(), v.size() * sizeof(Vec3));
  return out;
}

py::tuple load_mesh_arrays(const std::string& path) {
  Mesh mesh;
  {
    py::gil_scoped_release release;
    mesh = load_mesh(path);
  }
  py::array_t<std::uint32_t> faces({static_cast<py::ssize_t>(mesh.faces.size()), py::ssize_t{3}});
  if (!mesh.faces.empty())
    std::memcpy(faces.mutable_data(), mesh.faces.data(),
                mesh.faces.size() * 3 * sizeof(std::uint32_t));
  return py::make_tuple(vec3_array(mesh.positions), faces);
}

py::array_t<float> load_points_array(const std::string& path) {
  std::vector<Vec3> points;
  {
    py::gil_scoped_release release;
    points = load_points(path);
  }
  return vec3_array(points);
}

}  // namespace

void bind_io(py::module_& m) {
  m.def("load_mesh", &load_mesh_arrays, py::arg("path"));
  m.def("load_points", &load_points_array, py::arg("path"));
}

}  // namespace splitray::python

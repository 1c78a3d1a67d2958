// splitray._core: the compiled half of `import splitray` (python/splitray/__init__.py is the
// other). Every splitray::Error becomes a ValueError whose message names the file or argument.
#include <pybind11/pybind11.h>

#include "bindings.hpp"
#include "splitray/core/errors.hpp"

#ifndef SPLITRAY_VERSION
#error "SPLITRAY_VERSION is set by python/CMakeLists.txt"
#endif

PYBIND11_MODULE(_core, m) {
  m.doc() = "splitray: kd-trees, BVHs and neighbour search (the compiled core)";
  m.attr("__version__") = SPLITRAY_VERSION;
  pybind11::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const splitray::Error& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    }
  });
  splitray::python::bind_io(m);
  splitray::python::bind_scene(m);
  splitray::python::bind_kdtree(m);
}

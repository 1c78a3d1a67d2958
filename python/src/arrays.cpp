#include "arrays.hpp"

#include <limits>
#include <type_traits>

#include "splitray/core/parallel.hpp"

namespace splitray::python {

int worker_count(int workers, const char* name, bool zero_is_all) {
  if (workers == -1 || (zero_is_all && workers == 0)) return hardware_threads();
  if (workers < 1)
    throw py::value_error(std::string(name) + ": " + std::to_string(workers) +
                          " is not a thread count (a positive number, or -1 for all cores" +
                          (zero_is_all ? "; 0 likewise)" : ")"));
  return workers;
}

namespace {

std::string dtype_text(const py::array& a) { return py::str(a.dtype()).cast<std::string>(); }

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d) s += (d ? ", " : "") + std::to_string(a.shape(d));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

// obj as a NumPy array of numbers (lists and other array-likes are converted).
template <typename T>
py::array numeric_array(py::handle obj, const char* name) {
  py::array a;
  if (py::isinstance<py::array>(obj)) {
    a = py::reinterpret_borrow<py::array>(obj);
  } else {
    try {
      a = py::module_::import("numpy").attr("asarray")(obj);
    } catch (py::error_already_set& e) {
      throw py::type_error(std::string(name) + ": not convertible to a NumPy array (" + e.what() +
                           ")");
    }
  }
  const char kind = a.dtype().kind();
  const bool ok = std::is_integral_v<T> ? (kind == 'i' || kind == 'u')
                                        : (kind == 'f' || kind == 'i' || kind == 'u');
  if (!ok)
    throw py::type_error(std::string(name) + ": expected an array of " +
                         (std::is_integral_v<T> ? "integers" : "numbers") + ", got dtype " +
                         dtype_text(a));
  if (std::is_integral_v<T> && a.size() > 0) {
    if (kind == 'i') {
      const auto lowest = a.attr("min")().cast<long long>();
      if (lowest < 0)
        throw py::value_error(std::string(name) + ": negative index " + std::to_string(lowest));
    }
    if (a.dtype().itemsize() > static_cast<py::ssize_t>(sizeof(T))) {
      const auto highest = a.attr("max")().cast<unsigned long long>();
      if (highest > std::numeric_limits<T>::max())
        throw py::value_error(std::string(name) + ": index " + std::to_string(highest) +
                              " does not fit " + std::to_string(8 * sizeof(T)) + " bits");
    }
  }
  return a;
}

void check_shape(const py::array& a, py::ssize_t cols, const char* name, int min_ndim,
                 int max_ndim) {
  if (a.ndim() < min_ndim || a.ndim() > max_ndim || a.ndim() == 0 || a.shape(a.ndim() - 1) != cols)
    throw py::value_error(std::string(name) + ": expected shape " +
                          (max_ndim == 2 ? "(N, " : "(..., ") + std::to_string(cols) + "), got " +
                          shape_text(a));
}

}  // namespace

template <typename T>
py::array_t<T> rows_of(py::handle obj, py::ssize_t cols, const char* name, int min_ndim,
                       int max_ndim) {
  py::array a = numeric_array<T>(obj, name);
  check_shape(a, cols, name, min_ndim, max_ndim);
  return py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(a);
}

template <typename T>
py::array_t<T> matrix_of(py::handle obj, py::ssize_t cols, const char* name) {
  py::array a = numeric_array<T>(obj, name);
  check_shape(a, cols, name, 2, 2);
  const bool usable = py::isinstance<py::array_t<T>>(a) && a.strides(1) == sizeof(T) &&
                      a.strides(0) >= static_cast<py::ssize_t>(cols * sizeof(T)) &&
                      a.strides(0) % static_cast<py::ssize_t>(sizeof(T)) == 0;
  if (usable) return py::reinterpret_borrow<py::array_t<T>>(a);
  return py::array_t<T, py::array::c_style | py::array::forcecast>::ensure(a);
}

template py::array_t<float> rows_of<float>(py::handle, py::ssize_t, const char*, int, int);
template py::array_t<float> matrix_of<float>(py::handle, py::ssize_t, const char*);
template py::array_t<std::uint32_t> matrix_of<std::uint32_t>(py::handle, py::ssize_t, const char*);

std::vector<py::ssize_t> leading_shape(const py::array& a) {
  return std::vector<py::ssize_t>(a.shape(), a.shape() + a.ndim() - 1);
}

std::size_t row_count(const py::array& a) {
  std::size_t n = 1;
  for (py::ssize_t d = 0; d + 1 < a.ndim(); ++d) n *= static_cast<std::size_t>(a.shape(d));
  return n;
}

}  // namespace splitray::python

#pragma once
// NumPy arguments of the module: checked (TypeError for a dtype that is not a number,
// ValueError for a wrong shape or value, both naming the argument) and taken without a copy
// when they already have a layout the library reads.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <string>
#include <vector>

namespace splitray::python {

namespace py = pybind11;

// The thread count of `workers` (scipy) or `nthreads` (Open3D): -1 (and 0 where
// `zero_is_all`) = all cores; anything else below 1 is a ValueError naming `name`.
int worker_count(int workers, const char* name, bool zero_is_all);

// obj as a C-contiguous array of T whose last dimension is `cols`, with min_ndim..max_ndim
// dimensions: the input itself when it already is one, else a converted copy.
template <typename T>
py::array_t<T> rows_of(py::handle obj, py::ssize_t cols, const char* name, int min_ndim = 1,
                       int max_ndim = 32);

// obj as an (N, cols) matrix of T whose rows may be strided (each row's elements adjacent, as
// in a column slice of a wider array): the input itself when it is one, else a C-contiguous
// copy. Integer input is range-checked for T (negative or too large values: ValueError).
template <typename T>
py::array_t<T> matrix_of(py::handle obj, py::ssize_t cols, const char* name);

// The leading shape of an (..., cols) array, and the number of its rows.
std::vector<py::ssize_t> leading_shape(const py::array& a);
std::size_t row_count(const py::array& a);

}  // namespace splitray::python

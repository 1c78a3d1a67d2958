// The compiled half of splitray.KDTree (python/splitray/_kdtree.py shapes its answers as
// scipy's cKDTree does): a NeighborIndex over a NumPy array of points.
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "arrays.hpp"
#include "bindings.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/query/neighbor_index.hpp"

namespace splitray::python {

namespace {

using namespace pybind11::literals;

static_assert(sizeof(Vec3) == 3 * sizeof(float), "(N, 3) float32 rows are read as Vec3");

// A C-contiguous (..., 3) float32 array of finite points as Vec3s, in place.
std::span<const Vec3> points_of(const py::array_t<float>& a, const char* name) {
  const float* p = a.data();
  const std::size_t n = row_count(a);
  for (std::size_t i = 0; i < 3 * n; ++i)
    if (!std::isfinite(p[i]))
      throw py::value_error(std::string(name) + ": coordinate " + std::to_string(i % 3) +
                            " of point " + std::to_string(i / 3) + " is not finite");
  return {reinterpret_cast<const Vec3*>(p), n};
}

class CoreKDTree {
 public:
  CoreKDTree(py::handle data, int leafsize, const std::string& builder) {
    if (leafsize < 1)
      throw py::value_error("leafsize: must be at least 1, got " + std::to_string(leafsize));
    const auto names = neighbor_index_names();
    if (std::find(names.begin(), names.end(), builder) == names.end()) {
      std::string known;
      for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
      throw py::value_error("builder: unknown '" + builder + "' (known: " + known + ")");
    }
    data_ = rows_of<float>(data, 3, "data", 2, 2);
    if (data_.shape(0) == 0) throw py::value_error("data: no points");
    if (data_.shape(0) >= static_cast<py::ssize_t>(std::numeric_limits<std::uint32_t>::max()))
      throw py::value_error("data: more than 2**32 - 2 points");
    const std::span<const Vec3> points = points_of(data_, "data");
    NeighborIndexConfig config;
    config.builder = builder;
    config.leaf_size = leafsize;
    py::gil_scoped_release release;
    index_ = make_neighbor_index(points, config);
  }

  // The k nearest (k <= n) of each query as float64 distances and int64 indices, (N, k);
  // neighbours not closer than `bound` are (inf, n), as scipy's.
  py::tuple query(py::handle x, int k, double bound, int workers) const {
    const auto q = rows_of<float>(x, 3, "x", 2, 2);
    const std::span<const Vec3> queries = points_of(q, "x");
    const auto n = static_cast<std::int64_t>(index_->points());
    const std::size_t nq = queries.size();
    py::array_t<double> dist({static_cast<py::ssize_t>(nq), static_cast<py::ssize_t>(k)});
    py::array_t<std::int64_t> idx({static_cast<py::ssize_t>(nq), static_cast<py::ssize_t>(k)});
    double* dp = dist.mutable_data();
    std::int64_t* ip = idx.mutable_data();
    {
      py::gil_scoped_release release;
      tbb::task_arena(workers).execute([&] {
        const KnnResult r = index_->knn(queries, k);
        parallel_chunks(nq * k, 1 << 15, [&](std::size_t b, std::size_t e) {
          for (std::size_t i = b; i < e; ++i) {
            const double d = r.distances[i];
            const bool kept = d < bound;
            dp[i] = kept ? d : std::numeric_limits<double>::infinity();
            ip[i] = kept ? static_cast<std::int64_t>(r.indices[i]) : n;
          }
        });
      });
    }
    return py::make_tuple(dist, idx);
  }

  // Every point within r of each query: an object array (shape `shape`) of lists of indices
  // (sorted by index when `by_index`, else by distance), or their counts (`counts_only`).
  py::object query_ball_point(py::handle x, float r, int workers, bool by_index,
                              bool counts_only) const {
    if (!(r >= 0)) throw py::value_error("r: expected a radius >= 0, got " + std::to_string(r));
    const auto q = rows_of<float>(x, 3, "x", 2, 2);
    const std::span<const Vec3> queries = points_of(q, "x");
    RadiusResult found;
    {
      py::gil_scoped_release release;
      tbb::task_arena(workers).execute([&] {
        found = index_->radius(queries, r);
        if (by_index && !counts_only)
          parallel_chunks(queries.size(), 1024, [&](std::size_t b, std::size_t e) {
            for (std::size_t i = b; i < e; ++i)
              std::sort(found.indices.begin() + found.offsets[i],
                        found.indices.begin() + found.offsets[i + 1]);
          });
      });
    }
    const std::size_t nq = queries.size();
    if (counts_only) {
      py::array_t<std::int64_t> counts(static_cast<py::ssize_t>(nq));
      for (std::size_t i = 0; i < nq; ++i)
        counts.mutable_data()[i] =
            static_cast<std::int64_t>(found.offsets[i + 1] - found.offsets[i]);
      return counts;
    }
    py::array out = py::module_::import("numpy").attr("empty")(nq, "dtype"_a = "object");
    auto** cells = static_cast<PyObject**>(out.mutable_data());
    // Most of this call is making Python objects: each index becomes one int object shared by
    // every list that holds it, and the cyclic collector (which the millions of new lists would
    // otherwise wake many times over) pauses meanwhile; neither changes the answers.
    std::vector<PyObject*> ints(index_->points(), nullptr);
    const bool collecting = PyGC_Disable() != 0;
    for (std::size_t i = 0; i < nq; ++i) {
      const std::span<const std::uint32_t> ids = found.indices_of(i);
      PyObject* list = PyList_New(static_cast<py::ssize_t>(ids.size()));
      if (!list) break;
      for (std::size_t j = 0; j < ids.size(); ++j) {
        PyObject*& cell = ints[ids[j]];
        if (!cell) cell = PyLong_FromUnsignedLong(ids[j]);
        Py_XINCREF(cell);
        PyList_SET_ITEM(list, static_cast<py::ssize_t>(j), cell);
      }
      Py_XDECREF(cells[i]);  // the None numpy.empty put there
      cells[i] = list;
    }
    for (PyObject* cell : ints) Py_XDECREF(cell);
    if (collecting) PyGC_Enable();
    if (PyErr_Occurred()) throw py::error_already_set();
    return out;
  }

  std::size_t n() const { return index_->points(); }
  py::array data() const { return data_; }
  const std::string& builder() const { return index_->name(); }
  double build_ms() const { return index_->build_ms(); }

 private:
  py::array_t<float> data_;  // the points index_ references
  std::unique_ptr<NeighborIndex> index_;
};

}  // namespace

void bind_kdtree(py::module_& m) {
  py::class_<CoreKDTree>(m, "_KDTree")
      .def(py::init<py::handle, int, const std::string&>(), "data"_a, "leafsize"_a, "builder"_a)
      .def("query", &CoreKDTree::query, "x"_a, "k"_a, "distance_upper_bound"_a, "workers"_a)
      .def("query_ball_point", &CoreKDTree::query_ball_point, "x"_a, "r"_a, "workers"_a,
           "by_index"_a, "counts_only"_a)
      .def_property_readonly("n", &CoreKDTree::n)
      .def_property_readonly("data", &CoreKDTree::data)
      .def_property_readonly("builder", &CoreKDTree::builder)
      .def_property_readonly("build_ms", &CoreKDTree::build_ms);
  m.def("neighbor_index_names", &neighbor_index_names,
        "The builders KDTree accepts (the first is the default).");
}

}  // namespace splitray::python

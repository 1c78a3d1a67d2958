// splitray.Scene: MeshScene (accel/mesh_scene.hpp) over NumPy arrays, with the names and
// conventions of Open3D's RaycastingScene.
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <string>
#include <vector>

#include "arrays.hpp"
#include "bindings.hpp"
#include "splitray/accel/mesh_scene.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray::python {

namespace {

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

// The (N, 6) origins and directions as the library's rays, kRayBlock at a time into a buffer of
// each worker's own: body(first, rays) sees rays first .. first + rays.size() - 1. Tracing block
// by block writes the answers straight into the caller's arrays, with no array of all the rays
// or all the hits between. A ray with a non-finite component or a zero direction misses
// (Open3D's answer): Accel's domain (splitray/core/coordinates.hpp).
constexpr std::size_t kRayBlock = 256;

template <typename Body>
void for_ray_blocks(const float* r, std::size_t n, float tnear, float tfar, const Body& body) {
  parallel_chunks((n + kRayBlock - 1) / kRayBlock, 1, [&](std::size_t b, std::size_t e) {
    std::array<Ray, kRayBlock> rays;
    for (std::size_t block = b; block < e; ++block) {
      const std::size_t first = block * kRayBlock, count = std::min(kRayBlock, n - first);
      for (std::size_t i = 0; i < count; ++i) {
        const float* p = r + 6 * (first + i);
        rays[i] = Ray{{p[0], p[1], p[2]}, {p[3], p[4], p[5]}, tnear, tfar};
      }
      body(first, std::span<const Ray>(rays.data(), count));
    }
  });
}

py::object optional_float(const std::optional<double>& v) {
  return v ? py::object(py::float_(*v)) : py::object(py::none());
}

py::dict stats_dict(const AccelStats& s) {
  py::dict d;
  d["accel"] = s.accel;
  d["builder"] = s.builder;
  d["prims"] = s.prims;
  d["build_ms"] = s.build_ms;
  d["nodes"] = s.nodes;
  d["leaves"] = s.leaves;
  d["empty_leaves"] = s.empty_leaves;
  d["max_depth"] = s.max_depth;
  d["mean_leaf_depth"] = s.mean_leaf_depth;
  d["mean_leaf_prims"] = s.mean_leaf_prims;
  d["prim_refs"] = s.prim_refs;
  d["bytes"] = s.bytes;
  d["sah_cost"] = optional_float(s.sah_cost);
  // The K_T and K_I sah_cost was computed with (each structure's defaults: kd 70 / 20, else 15 /
  // 20).
  d["sah_kt"] = s.sah_cost ? py::object(py::float_(s.sah_traversal_cost)) : py::object(py::none());
  d["sah_ki"] =
      s.sah_cost ? py::object(py::float_(s.sah_intersection_cost)) : py::object(py::none());
  d["sah_node_steps"] = optional_float(s.sah_node_steps);
  d["sah_triangle_tests"] = optional_float(s.sah_triangle_tests);
  d["cost_evals"] = s.cost_evals;
  return d;
}

// The caller's arrays as MeshBuffers: strided rows are read in place.
MeshBuffers buffers(const py::array_t<float>& v, const py::array_t<std::uint32_t>& f) {
  MeshBuffers m;
  m.vertices = v.data();
  m.vertex_count = static_cast<std::size_t>(v.shape(0));
  m.vertex_stride = static_cast<std::size_t>(v.strides(0));
  m.indices = f.data();
  m.triangle_count = static_cast<std::size_t>(f.shape(0));
  m.index_stride = static_cast<std::size_t>(f.strides(0));
  return m;
}

class Scene {
 public:
  Scene(py::handle vertices, py::handle triangles, const std::string& accel,
        const std::string& builder, int threads) {
    const auto names = accel_names();
    if (std::find(names.begin(), names.end(), accel) == names.end())
      throw py::value_error("accel: unknown structure '" + accel + "' (known: " + join(names) +
                            ")");
    const auto builders = builder_names(accel);
    if (!builder.empty() &&
        std::find(builders.begin(), builders.end(), builder) == builders.end() &&
        !(builder == "neural" && has_neural_builder(accel)))
      throw py::value_error("builder: '" + builder + "' is not a builder of accel '" + accel +
                            "' (known: " + join(builders) +
                            (has_neural_builder(accel) ? ", neural" : "") + ")");
    threads_ = worker_count(threads, "threads", true);
    vertices_ = matrix_of<float>(vertices, 3, "vertices");
    triangles_ = matrix_of<std::uint32_t>(triangles, 3, "triangles");
    BuildConfig config;
    config.builder = builder;
    const MeshBuffers mesh = buffers(vertices_, triangles_);
    py::gil_scoped_release release;
    tbb::task_arena(threads_).execute(
        [&] { scene_ = std::make_unique<MeshScene>(mesh, accel, config, "vertices/triangles"); });
  }

  std::string update(py::handle vertices) {
    auto v = matrix_of<float>(vertices, 3, "vertices");
    MeshUpdate how;
    {
      py::gil_scoped_release release;
      std::unique_lock lock(mutex_);  // waits for casts running in other Python threads
      tbb::task_arena(threads_).execute(
          [&] { how = scene_->update(buffers(v, triangles_), "vertices"); });
    }
    vertices_ = v;  // the previous array is released only now that the scene left it
    return mesh_update_name(how);
  }

  py::dict cast_rays(py::handle rays_obj, int nthreads) {
    const auto rays = rows_of<float>(rays_obj, 6, "rays");
    const int workers = worker_count(nthreads, "nthreads", true);
    const auto shape = leading_shape(rays);
    const std::size_t n = row_count(rays);
    auto uv_shape = shape, normal_shape = shape;
    uv_shape.push_back(2);
    normal_shape.push_back(3);
    py::array_t<float> t(shape), uvs(uv_shape), normals(normal_shape);
    py::array_t<std::uint32_t> ids(shape), geometry(shape);
    const float* r = rays.data();
    float *tp = t.mutable_data(), *uvp = uvs.mutable_data(), *np = normals.mutable_data();
    std::uint32_t *idp = ids.mutable_data(), *gp = geometry.mutable_data();
    {
      py::gil_scoped_release release;
      std::shared_lock lock(mutex_);
      tbb::task_arena(workers).execute([&] {
        for_ray_blocks(r, n, 0, kInfinity, [&](std::size_t first, std::span<const Ray> block) {
          std::array<Hit, kRayBlock> hits;
          scene_->accel().intersect(block, std::span<Hit>(hits.data(), block.size()));
          // The normals of MeshScene::fill_normal, without its intermediate SurfaceHits.
          for (std::size_t j = 0; j < block.size(); ++j) {
            const Hit& h = hits[j];
            const std::size_t i = first + j;
            tp[i] = h.t;
            idp[i] = h.prim;
            gp[i] = h.found() ? 0 : kInvalidId;
            uvp[2 * i] = h.found() ? h.u : 0;
            uvp[2 * i + 1] = h.found() ? h.v : 0;
            const Vec3 ng = h.found() ? scene_->geometric_normal(h.prim) : Vec3{0, 0, 0};
            const Vec3 unit = normalize(ng);  // as `splitray trace --hits-out`
            np[3 * i] = unit.x;
            np[3 * i + 1] = unit.y;
            np[3 * i + 2] = unit.z;
          }
        });
      });
    }
    py::dict out;
    out["t_hit"] = t;
    out["geometry_ids"] = geometry;
    out["primitive_ids"] = ids;
    out["primitive_uvs"] = uvs;
    out["primitive_normals"] = normals;
    return out;
  }

  py::array_t<bool> test_occlusions(py::handle rays_obj, float tnear, float tfar, int nthreads) {
    const auto rays = rows_of<float>(rays_obj, 6, "rays");
    const int workers = worker_count(nthreads, "nthreads", true);
    if (!(tnear >= 0) || std::isnan(tfar) || tfar < tnear)
      throw py::value_error("tnear, tfar: expected 0 <= tnear <= tfar, got " +
                            std::to_string(tnear) + ", " + std::to_string(tfar));
    py::array_t<bool> out(leading_shape(rays));
    const std::size_t n = row_count(rays);
    bool* op = out.mutable_data();
    const float* r = rays.data();
    {
      py::gil_scoped_release release;
      std::shared_lock lock(mutex_);
      tbb::task_arena(workers).execute([&] {
        for_ray_blocks(r, n, tnear, tfar, [&](std::size_t first, std::span<const Ray> block) {
          std::array<std::uint8_t, kRayBlock> occluded;
          scene_->occluded(block, std::span<std::uint8_t>(occluded.data(), block.size()));
          for (std::size_t j = 0; j < block.size(); ++j) op[first + j] = occluded[j] != 0;
        });
      });
    }
    return out;
  }

  py::dict stats() const {
    std::shared_lock lock(mutex_);
    return stats_dict(scene_->stats());
  }
  const std::string& accel() const { return scene_->accel_name(); }
  py::array vertices() const { return vertices_; }
  py::array triangles() const { return triangles_; }

 private:
  int threads_ = 1;
  py::array_t<float> vertices_;  // the arrays scene_'s MeshBuffers point into
  py::array_t<std::uint32_t> triangles_;
  std::unique_ptr<MeshScene> scene_;
  mutable std::shared_mutex mutex_;  // update() against casts from other Python threads
};

}  // namespace

void bind_scene(py::module_& m) {
  py::class_<Scene>(m, "Scene", R"doc(
Rays against an indexed triangle mesh, with Open3D RaycastingScene's names and conventions.

vertices: (V, 3) float array; float32 rows are used in place (C-contiguous, or rows of a
wider array such as a[:, :3]), anything else is converted once. triangles: (M, 3) integer
array of vertex indices (uint32 used in place). accel: one of accel_names() ("bvh", "kd",
"bih", "embree", "brute"); builder: one of builder_names(accel), "" = the structure's default;
threads: build threads, 0 or -1 = all cores.

The structure keeps its own copy of the triangles in its own layout. The Scene references
both arrays (hits take their normals from them): change the vertices only through update().
)doc")
      .def(py::init<py::handle, py::handle, const std::string&, const std::string&, int>(),
           py::arg("vertices"), py::arg("triangles"), py::arg("accel") = "bvh",
           py::arg("builder") = "", py::arg("threads") = 0)
      .def("cast_rays", &Scene::cast_rays, py::arg("rays"), py::arg("nthreads") = 0, R"doc(
Closest hits of rays given as an (..., 6) float array of origins and directions (directions
need not be unit length; t is in their units). Returns a dict of arrays shaped like the rays'
leading dimensions: t_hit (float32, inf on a miss), geometry_ids and primitive_ids (uint32,
2**32 - 1 on a miss), primitive_uvs (..., 2: barycentrics of vertices 1 and 2, 0 on a miss),
primitive_normals (..., 3: the unit geometric normal of (v1 - v0) x (v2 - v0), 0 on a miss).
Ties (rays through shared edges) go to the smaller triangle index; a ray with a NaN or
infinite component or a zero direction misses. nthreads: 0 or -1 = all cores; the answers
never depend on it. The GIL is released while tracing.
)doc")
      .def("test_occlusions", &Scene::test_occlusions, py::arg("rays"), py::arg("tnear") = 0.0f,
           py::arg("tfar") = kInfinity, py::arg("nthreads") = 0, R"doc(
Whether anything is hit with tnear <= t <= tfar along each ray ((..., 6) float array).
Returns a bool array of the rays' leading shape.
)doc")
      .def("update", &Scene::update, py::arg("vertices"), R"doc(
Moves the mesh to new positions of its vertices (same count, same triangles) for animated
meshes: a refit where the structure refits (bvh; embree with builder "refit"), for kd a
rebuild steered by the Kalman-filtered split planes of the previous frames (paper 000),
otherwise a full rebuild. Returns "refit", "predicted_rebuild" or "rebuild".
)doc")
      .def_property_readonly("stats", &Scene::stats, "The structure's statistics as a dict.")
      .def_property_readonly("accel", &Scene::accel, "The structure's name.")
      .def_property_readonly("vertices", &Scene::vertices, "The vertex array the scene reads.")
      .def_property_readonly("triangles", &Scene::triangles, "The index array (uint32).");
  m.def("accel_names", &accel_names, "The structures Scene's accel accepts.");
  m.def("builder_names", &builder_names, py::arg("accel"),
        "The builders of a structure (the first is its default).");
}

}  // namespace splitray::python

#pragma once
// The meshes the benchmarks run on: the vendored ones (always there) and every real static
// mesh or first frame of ../shared/data, each with a camera that sees it the way a user
// would: from outside an object, from inside a closed room or church.
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "splitray/core/camera.hpp"
#include "splitray/core/triangle.hpp"

namespace splitray::bench {

struct BenchMesh {
  std::string name;              // short, unique; what --meshes selects
  std::string path;              // resolved file path
  std::optional<Camera> camera;  // none = fit_camera (outside the object)
  std::string view;              // "outside" or "inside (...)" for the reports
};

// A camera outside the object, looking at it from the direction of Camera::frame (front,
// right, above) from as close as it can while every vertex stays in the view of the primary
// ray grid (4:3): the object fills the picture instead of a fraction of it.
Camera fit_camera(std::span<const Triangle> triangles, float vfov_degrees = 45);

// `count` viewpoints of a mesh from `base` (the first is `base`): turned about the camera's up
// axis in equal steps, about the eye when it lies inside `bounds` (looking around a room), else
// about the target (walking around an object). Measuring from several viewpoints keeps a
// result from depending on one picture.
std::vector<Camera> turned_views(const Camera& base, int count, const Aabb& bounds);

// A mesh's path as reports show it: relative to the working folder (no machine's absolute
// paths in results that are committed).
std::string report_path(const std::string& path);

// ../shared/data next to the source tree, or $SPLITRAY_SHARED_DATA; "" if absent.
std::string shared_data_dir();

// Every benchmark mesh that is present, in a fixed order (vendored first). `quick`: only the
// two vendored meshes. Absent shared files are left out with a note in `notes`.
std::vector<BenchMesh> benchmark_meshes(bool quick, std::vector<std::string>& notes);

// Picks meshes by name from `all`; an entry that names no mesh but an existing file becomes
// a mesh of its own (viewed from outside). An entry may end in @EX,EY,EZ,TX,TY,TZ[,FOV], the
// camera to measure from (e.g. inside a room). Throws Error("--meshes", ...) otherwise.
std::vector<BenchMesh> select_meshes(const std::vector<BenchMesh>& all,
                                     const std::vector<std::string>& wanted);

}  // namespace splitray::bench

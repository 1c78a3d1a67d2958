#include "bench_meshes.hpp"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numbers>

#include "camera_option.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/render/data_dir.hpp"

namespace splitray::bench {

namespace {

namespace fs = std::filesystem;

struct Known {
  const char* name;
  const char* relative;  // under ../shared/data
  std::optional<Camera> camera;
  const char* view;
};

Camera look(Vec3 eye, Vec3 target, float vfov) {
  Camera camera;
  camera.eye = eye;
  camera.target = target;
  camera.vfov_degrees = vfov;
  return camera;
}

// Static meshes and the first frame of each sequence. The vendored dragon and horse are
// byte-identical to static_dragon_100k/dragon.obj and the horse-collapse reference, so those
// two are not repeated. BART scenes (AFF) have no loader yet.
const std::vector<Known>& shared_meshes() {
  static const std::vector<Known> meshes = {
      // The view of ../shared/data/README.md: down the nave, every pixel hits.
      {"sibenik", "static_sibenik/sibenik.obj", look({-17, -13.6f, 0}, {19, -9, 0}, 60),
       "inside the church"},
      // A closed box (front wall included): from just inside the front wall to the back wall.
      {"cornell_box", "static_cornell_box/cornell_box.obj",
       look({278, 274, 20}, {278, 274, 559}, 60), "inside the room"},
      {"cat", "static_sumner_cat_lion_poses/cat-poses/cat-reference.obj.gz", std::nullopt,
       "outside"},
      {"lion", "static_sumner_cat_lion_poses/lion-poses/lion-reference.obj.gz", std::nullopt,
       "outside"},
      {"elephant", "anim_elephant_gallop/frames/elephant-gallop-01.obj.gz", std::nullopt,
       "outside"},
      {"samba", "anim_samba/frames/samba_0000.obj.gz", std::nullopt, "outside"},
      {"walking_cat", "anim_walking_cat/frames/mesh.01.obj", std::nullopt, "outside"},
      {"faerie", "anim_md2_faerie/frames/faerie_000.obj", std::nullopt, "outside"},
      {"cesium_man", "skinned_khronos_gltf1/CesiumMan/collada/CesiumMan.dae", std::nullopt,
       "outside"},
      {"armadillo_rollers", "anim_ccd_frame_pairs/armadillo-rollers/frames/326.ply", std::nullopt,
       "outside"},
      {"cloth_funnel", "anim_ccd_frame_pairs/cloth-funnel/frames/227.ply", std::nullopt, "outside"},
      {"rod_twist", "anim_ccd_frame_pairs/rod-twist/frames/3036.ply", std::nullopt, "outside"},
      {"n_body", "anim_ccd_frame_pairs/n-body-simulation/frames/balls16_18.ply", std::nullopt,
       "outside"},
  };
  return meshes;
}

}  // namespace

Camera fit_camera(std::span<const Triangle> triangles, float vfov_degrees) {
  Aabb box;
  for (const Triangle& t : triangles) box.extend(t.bounds());
  Camera camera = Camera::frame(box, vfov_degrees);
  // The eye moves along the axis target -> eye; the image-plane coordinates of a vertex do
  // not depend on the distance, its depth grows with it: solve for the closest distance.
  const Vec3 back = normalize(camera.eye - camera.target), forward = -back;
  const Vec3 right = normalize(cross(forward, camera.up)), up = cross(right, forward);
  const float tan_half = std::tan(vfov_degrees * std::numbers::pi_v<float> / 360.0f);
  constexpr float kAspect = 4.0f / 3.0f, kMargin = 1.05f;
  float distance = 0;
  for (const Triangle& t : triangles) {
    for (int k = 0; k < 3; ++k) {
      const Vec3 q = t.vertex(k) - camera.target;
      const float needed = std::max(std::fabs(dot(q, up)) / tan_half,
                                    std::fabs(dot(q, right)) / (tan_half * kAspect));
      distance = std::max(distance, kMargin * needed - dot(q, forward));
    }
  }
  camera.eye = camera.target + back * std::max(distance, 1e-6f);
  return camera;
}

std::vector<Camera> turned_views(const Camera& base, int count, const Aabb& bounds) {
  const Vec3 axis = normalize(base.up);
  const bool inside = bounds.contains(base.eye);
  std::vector<Camera> views;
  for (int k = 0; k < count; ++k) {
    const float angle =
        2 * std::numbers::pi_v<float> * static_cast<float>(k) / static_cast<float>(count);
    const float c = std::cos(angle), s = std::sin(angle);
    // Rodrigues' rotation of v about the unit axis.
    const auto turn = [&](const Vec3& v) {
      return v * c + cross(axis, v) * s + axis * (dot(axis, v) * (1 - c));
    };
    Camera view = base;
    if (inside)
      view.target = base.eye + turn(base.target - base.eye);
    else
      view.eye = base.target + turn(base.eye - base.target);
    views.push_back(view);
  }
  return views;
}

std::string report_path(const std::string& path) {
  std::error_code error;
  const fs::path relative = fs::proximate(path, error);
  return error ? path : relative.string();
}

std::string shared_data_dir() {
  if (const char* env = std::getenv("SPLITRAY_SHARED_DATA")) return env;
  const fs::path beside = fs::path(SPLITRAY_SOURCE_DIR).parent_path() / "shared" / "data";
  return fs::is_directory(beside) ? beside.string() : std::string{};
}

std::vector<BenchMesh> benchmark_meshes(bool quick, std::vector<std::string>& notes) {
  std::vector<BenchMesh> meshes = {
      {"horse", find_data_file("horse/horse.obj.gz"), std::nullopt, "outside"},
      {"dragon", find_data_file("dragon_100k/dragon.obj.gz"), std::nullopt, "outside"},
  };
  if (quick) return meshes;
  const std::string dir = shared_data_dir();
  if (dir.empty()) {
    notes.push_back("../shared/data is absent: only the vendored meshes were measured");
    return meshes;
  }
  for (const Known& known : shared_meshes()) {
    const fs::path path = fs::path(dir) / known.relative;
    if (!fs::exists(path)) {
      notes.push_back(std::string(known.relative) + " is absent: skipped");
      continue;
    }
    meshes.push_back({known.name, path.string(), known.camera, known.view});
  }
  return meshes;
}

std::vector<BenchMesh> select_meshes(const std::vector<BenchMesh>& all,
                                     const std::vector<std::string>& wanted) {
  if (wanted.empty()) return all;
  std::vector<BenchMesh> selected;
  for (const std::string& entry : wanted) {
    // NAME or FILE, optionally @EX,EY,EZ,TX,TY,TZ[,FOV]: the camera to measure from.
    const std::size_t at = entry.rfind('@');
    const std::string name = entry.substr(0, at);
    std::optional<Camera> camera;
    if (at != std::string::npos)
      camera = cli::to_camera(cli::parse_camera(entry.substr(at + 1), "--meshes " + entry),
                              Camera{}.vfov_degrees);
    bool found = false;
    for (const BenchMesh& mesh : all) {
      if (mesh.name != name) continue;
      selected.push_back(mesh);
      if (camera) selected.back().camera = camera, selected.back().view = "given camera";
      found = true;
    }
    if (found) continue;
    if (!fs::is_regular_file(name)) {
      std::string known;
      for (const BenchMesh& mesh : all) known += (known.empty() ? "" : ", ") + mesh.name;
      throw Error("--meshes",
                  "'" + name + "' is neither a benchmark mesh (" + known + ") nor a mesh file");
    }
    selected.push_back(
        {fs::path(name).stem().string(), name, camera, camera ? "given camera" : "outside"});
  }
  return selected;
}

}  // namespace splitray::bench

#include "splitray/accel/mesh_scene.hpp"

#include <cstring>
#include <vector>

#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

const char* mesh_update_name(MeshUpdate update) {
  switch (update) {
    case MeshUpdate::refit:
      return "refit";
    case MeshUpdate::predicted_rebuild:
      return "predicted_rebuild";
    case MeshUpdate::rebuild:
      return "rebuild";
  }
  return "?";
}

MeshScene::MeshScene(const MeshBuffers& mesh, const std::string& accel, const BuildConfig& config,
                     const std::string& where)
    : mesh_(mesh), accel_name_(accel), config_(config) {
  accel_ = make_accel(accel, mesh, config, where);
  compute_normals();
}

void MeshScene::compute_normals() {
  normals_.resize(mesh_.triangle_count);
  parallel_chunks(normals_.size(), 4096, [&](std::size_t b, std::size_t e) {
    for (std::size_t j = b; j < e; ++j) normals_[j] = mesh_.triangle(j).geometric_normal();
  });
}

void MeshScene::fill_normal(SurfaceHit& hit) const {
  hit.ng = hit.found() ? normals_[hit.prim] : Vec3{0, 0, 0};
}

SurfaceHit MeshScene::intersect(const Ray& ray) const {
  SurfaceHit hit;
  static_cast<Hit&>(hit) = accel_->intersect(ray);
  fill_normal(hit);
  return hit;
}

void MeshScene::intersect(std::span<const Ray> rays, std::span<SurfaceHit> hits) const {
  if (hits.size() != rays.size()) throw Error("MeshScene::intersect", "one hit per ray expected");
  std::vector<Hit> found(rays.size());
  accel_->intersect(rays, found);
  parallel_chunks(rays.size(), 4096, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      static_cast<Hit&>(hits[i]) = found[i];
      fill_normal(hits[i]);
    }
  });
}

MeshUpdate MeshScene::update(const MeshBuffers& moved, const std::string& where) {
  if (moved.vertex_count != mesh_.vertex_count || moved.triangle_count != mesh_.triangle_count)
    throw Error(where, "an update keeps the mesh's " + std::to_string(mesh_.vertex_count) +
                           " vertices and " + std::to_string(mesh_.triangle_count) +
                           " triangles, got " + std::to_string(moved.vertex_count) + " and " +
                           std::to_string(moved.triangle_count));
  moved.validate(where);
  for (std::size_t j = 0; j < moved.triangle_count; ++j)
    if (std::memcmp(moved.triangle_indices(j), mesh_.triangle_indices(j),
                    3 * sizeof(std::uint32_t)) != 0)
      throw Error(where, "triangle " + std::to_string(j) +
                             " has other vertices than when built (an update moves vertices only)");
  const std::vector<Triangle> tris = moved.triangles();
  MeshUpdate how = MeshUpdate::rebuild;
  if (accel_->refit(tris)) {
    how = MeshUpdate::refit;
  } else if (accel_name_ == "kd") {
    if (!coherent_) {
      BuildConfig golden = config_;
      golden.builder = "golden";
      coherent_ = std::make_unique<KdCoherentBuilder>(golden, PredictorConfig{});
    }
    CoherentFrameStats stats;
    accel_ = coherent_->next_frame(tris, stats);
    how = MeshUpdate::predicted_rebuild;
  } else {
    accel_ = make_accel(accel_name_, tris, config_);
  }
  mesh_ = moved;
  compute_normals();
  return how;
}

}  // namespace splitray

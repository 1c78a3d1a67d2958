#pragma once
// A structure over a mesh in the caller's buffers, as an application uses one (Embree's
// RTCScene, Open3D's RaycastingScene): closest hits with the geometric normal, occlusion,
// and updates of the vertex positions for animated meshes. The Python module's Scene is
// this class.
//
// Memory: the structure keeps its own copy of the triangles in its own layout; the scene also
// keeps the MeshBuffers it was given (pointers, not copies) and the geometric normal of every
// triangle computed from them (12 bytes per triangle: a hit then reads one normal instead of
// three indices and three vertices scattered over the caller's memory, which cost 5-15% of the
// throughput of cast_rays). The buffers must stay alive and unchanged until update() moves the
// scene to other buffers or the scene is destroyed (Embree's rule for shared buffers).
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/accel/kd/coherent_builder.hpp"
#include "splitray/accel/mesh_buffers.hpp"
#include "splitray/accel/predict/split_predictor.hpp"

namespace splitray {

// A closest hit with the geometric normal ng = (v1 - v0) x (v2 - v0) of the triangle hit, not
// normalised (as Embree's Ng), from the caller's vertices; zero on a miss.
struct SurfaceHit : Hit {
  Vec3 ng;
};

enum class MeshUpdate { refit, predicted_rebuild, rebuild };
const char* mesh_update_name(MeshUpdate update);  // "refit", "predicted_rebuild", "rebuild"

class MeshScene {
 public:
  // Validates the buffers (Error naming `where`) and builds structure `accel` over them.
  MeshScene(const MeshBuffers& mesh, const std::string& accel = "bvh",
            const BuildConfig& config = {}, const std::string& where = "mesh buffers");

  SurfaceHit intersect(const Ray& ray) const;
  bool occluded(const Ray& ray) const { return accel_->occluded(ray); }
  // Batched over all cores (of the calling task arena); identical to the single-ray calls.
  void intersect(std::span<const Ray> rays, std::span<SurfaceHit> hits) const;
  void occluded(std::span<const Ray> rays, std::span<std::uint8_t> occluded) const {
    accel_->occluded(rays, occluded);
  }

  // Moves the scene to new positions of the same vertices (same vertex and triangle counts and
  // indices; `moved` replaces the buffers kept). How: a refit where the structure refits (bvh,
  // embree with builder "refit"); for kd the coherent rebuild from the previous update's tree
  // and the Kalman-filtered splits (kd/coherent_builder.hpp, "predicted_rebuild"); else a full
  // rebuild.
  MeshUpdate update(const MeshBuffers& moved, const std::string& where = "mesh buffers");

  const Accel& accel() const { return *accel_; }
  const AccelStats& stats() const { return accel_->stats(); }
  const MeshBuffers& mesh() const { return mesh_; }
  const std::string& accel_name() const { return accel_name_; }
  // The geometric normal of triangle `prim`, as SurfaceHit::ng.
  const Vec3& geometric_normal(std::uint32_t prim) const { return normals_[prim]; }

 private:
  void fill_normal(SurfaceHit& hit) const;

  void compute_normals();

  MeshBuffers mesh_;
  std::vector<Vec3> normals_;  // of every triangle of mesh_
  std::string accel_name_;
  BuildConfig config_;
  std::unique_ptr<Accel> accel_;
  std::unique_ptr<KdCoherentBuilder> coherent_;  // kd only: the frames so far
};

}  // namespace splitray

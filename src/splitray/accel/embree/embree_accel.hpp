#pragma once
// Embree 3 behind the common interface: the yardstick (builders low|medium|high|refit, and
// low|medium-robust with Embree's robust mode, RTC_SCENE_FLAG_ROBUST).
#include <span>

#include "splitray/accel/accel.hpp"

namespace splitray {

std::unique_ptr<Accel> make_embree(std::span<const Triangle> triangles, const BuildConfig& config);

// An Embree scene that follows an animation (`splitray animate --accel embree`): update()
// moves the vertices (the triangle count must stay) and commits the scene again, as a user
// of Embree does every frame. Builder "refit" refits the BVH (scene quality LOW, geometry
// quality REFIT, dynamic scene: Embree's prescription for deforming meshes); low, medium and
// high rebuild it.
class EmbreeScene : public Accel {
 public:
  // Returns the milliseconds of the vertex upload and commit.
  virtual double update(std::span<const Triangle> triangles) = 0;
};

std::unique_ptr<EmbreeScene> make_embree_scene(std::span<const Triangle> triangles,
                                               const BuildConfig& config);

}  // namespace splitray

#pragma once
// Shadow-map projections: light-space perspective shadow maps (LiSPSM, Wimmer et al. 2004)
// for directional lights, and the six 90-degree faces of a cube map for point lights.
#include <array>

#include <glm/glm.hpp>

#include "splitray/core/camera.hpp"

namespace splitray::gl {

// The view-projection of the camera as OpenGL renders it (pixel centres on Camera::generate's
// rays), near and far fitted to `bounds`.
glm::mat4 camera_matrix(const Camera& camera, int width, int height, const Aabb& bounds);

// Light view-projection for a directional light travelling along `light_dir`: LiSPSM fitted
// to the part of the view frustum inside `bounds` (uniform when `lispsm` is false or the view
// looks along the light), depth range covering every caster in `bounds`.
glm::mat4 directional_light_matrix(const Camera& camera, float aspect, const Vec3& light_dir,
                                   const Aabb& bounds, bool lispsm);

// The six face matrices of a cube map at `position` (GL face order +x, -x, +y, -y, +z, -z).
std::array<glm::mat4, 6> cube_face_matrices(const Vec3& position, float range);

}  // namespace splitray::gl

#pragma once
// Lights for scenes that bring none (a bare mesh, a JSON scene without "lights"), placed for
// what the camera sees, and the check that a scene's lights reach anything the camera sees.
// Both look at the scene through a coarse grid of camera rays traced through its hierarchy.
#include <optional>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/core/camera.hpp"
#include "splitray/core/scene.hpp"

namespace splitray {

// Outside the scene's bounds: one point light above and behind the camera (a key light that
// lights the side facing the camera). Inside them (a room, a nave): a head light at the camera
// plus a key light in free space between the camera and what it looks at, raised halfway to
// the ceiling. Intensities make the median visible distance receive radiance ~1 (1/d^2).
std::vector<Light> fit_lights(const FlatScene& flat, const Accel& accel, const Camera& camera,
                              int width, int height);

// The scene's lights, or fit_lights when the scene has none of its own (lights_fit_view).
std::vector<Light> lights_for_view(const Scene& scene, const FlatScene& flat, const Accel& accel,
                                   const Camera& camera, int width, int height);

struct LightCoverage {
  int probes = 0;  // camera rays of the grid that hit the scene
  int lit = 0;     // of those, points that a light reaches (facing it, unoccluded)
};
LightCoverage light_coverage(const std::vector<Light>& lights, const FlatScene& flat,
                             const Accel& accel, const Camera& camera, int width, int height);

// A warning for the user when the camera sees nothing, or no light reaches what it sees;
// empty when all is well.
std::string coverage_warning(const LightCoverage& coverage, std::size_t light_count);

}  // namespace splitray

#pragma once
// Pinhole look-at camera.
#include <string>

#include "splitray/core/aabb.hpp"
#include "splitray/core/ray.hpp"

namespace splitray {

struct Camera {
  Vec3 eye{0, 0, 5};
  Vec3 target{0, 0, 0};
  Vec3 up{0, 1, 0};
  float vfov_degrees = 60;

  // Ray through image position (x, y) in pixels, (0, 0) the top-left corner of the image.
  Ray generate(float x, float y, int width, int height) const;
  // A camera outside `box` looking at its centre from the front-right-above, seeing all of it.
  static Camera frame(const Aabb& box, float vfov_degrees = 45);
  // Why the camera makes no usable rays (an eye or target beyond the ray-origin limit of
  // coordinates.hpp, the same point, a zero up vector, a field of view outside (0, 180)), or ""
  // when it is fine.
  std::string problem() const;
};

}  // namespace splitray

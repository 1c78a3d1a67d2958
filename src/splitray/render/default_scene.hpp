#pragma once
// The built-in default scene: a room with reflective and refractive objects and the
// vendored Stanford dragon (data/dragon_100k), generated in code.
#include "splitray/core/scene.hpp"

namespace splitray {

Scene default_scene();

}  // namespace splitray

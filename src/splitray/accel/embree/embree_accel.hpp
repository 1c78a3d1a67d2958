#pragma once
// Embree 3 behind the common interface: the yardstick (builders low|medium|high).
#include "splitray/accel/accel.hpp"

namespace splitray {

std::unique_ptr<Accel> make_embree(std::span<const Triangle> triangles, const BuildConfig& config);

}  // namespace splitray

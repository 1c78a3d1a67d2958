#pragma once
// The BIH behind the common interface: --accel bih --builder global|median|middle|sah.
#include "splitray/accel/accel.hpp"

namespace splitray {

std::unique_ptr<Accel> make_bih(std::span<const Triangle> triangles, const BuildConfig& config);

}  // namespace splitray

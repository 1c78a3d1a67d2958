#pragma once
// The BVH behind the common interface: --accel bvh --builder binned|sbvh.
#include "splitray/accel/accel.hpp"

namespace splitray {

std::unique_ptr<Accel> make_bvh(std::span<const Triangle> triangles, const BuildConfig& config);

}  // namespace splitray

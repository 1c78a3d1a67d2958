#pragma once
// The BVH behind the common interface: --accel bvh --builder binned|sbvh|embree, and any Bvh
// built elsewhere (the neural builder's inferred top).
#include "splitray/accel/accel.hpp"

namespace splitray {

class Bvh;

std::unique_ptr<Accel> make_bvh(std::span<const Triangle> triangles, const BuildConfig& config);

// A built Bvh as an Accel: statistics with config's SAH constants (the BVH's defaults where
// unset), `build_ms` as its build time; refit as Bvh::refit.
std::unique_ptr<Accel> wrap_bvh(Bvh bvh, const BuildConfig& config, double build_ms);

}  // namespace splitray

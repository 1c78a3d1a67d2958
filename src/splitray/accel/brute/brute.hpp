#pragma once
// Every triangle tested against every ray: the oracle of the tests.
#include "splitray/accel/accel.hpp"

namespace splitray {

std::unique_ptr<Accel> make_brute(std::span<const Triangle> triangles, const BuildConfig& config);

}  // namespace splitray

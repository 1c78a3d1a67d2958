#pragma once
// The SAH kd-tree behind the common interface.
#include "splitray/accel/accel.hpp"

namespace splitray {

// Builders of --accel kd, the default first.
std::vector<std::string> kd_builder_names();
std::unique_ptr<Accel> make_kd(std::span<const Triangle> triangles, const BuildConfig& config);

}  // namespace splitray

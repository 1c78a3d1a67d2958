// Placeholder while the binned builder is being written (issue 3); replaced by its helper.
#include "splitray/accel/kd/kd_build.hpp"
#include "splitray/core/errors.hpp"

namespace splitray {

KdBuildResult build_kd_binned(std::span<const Triangle>, const Aabb&, const BuildConfig&) {
  throw Error("--builder binned", "not available yet");
}

}  // namespace splitray

// Placeholder while the golden builder is being written (issue 3); replaced by its helper.
#include "splitray/accel/kd/kd_build.hpp"
#include "splitray/core/errors.hpp"

namespace splitray {

KdBuildResult build_kd_golden(std::span<const Triangle>, const Aabb&, const BuildConfig&) {
  throw Error("--builder golden", "not available yet");
}

}  // namespace splitray

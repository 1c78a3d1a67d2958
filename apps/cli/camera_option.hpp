#pragma once
// --camera EX,EY,EZ,TX,TY,TZ[,FOV], the same in every front end (the program's commands and the
// benchmarks): eye, target and an optional vertical field of view, checked as CLI11 parses it.
#include <CLI/CLI.hpp>
#include <optional>
#include <string>

#include "splitray/core/camera.hpp"

namespace splitray::cli {

struct CameraSpec {
  Vec3 eye, target;
  std::optional<float> vfov_degrees;
};
// The problem with a camera string, or "" when it parses (then `out` holds it).
std::string camera_problem(const std::string& text, CameraSpec& out);
// Throws Error(`option`, ...) naming the problem.
CameraSpec parse_camera(const std::string& text, const std::string& option = "--camera");
// The camera of a spec; `default_vfov` when the spec has no FOV. Up is +y unless the view
// is vertical, then +z.
Camera to_camera(const CameraSpec& spec, float default_vfov);
// Adds -c/--camera to `command`, checked by camera_problem as CLI11 parses it.
CLI::Option* add_camera_option(CLI::App& command, std::string& text);

}  // namespace splitray::cli

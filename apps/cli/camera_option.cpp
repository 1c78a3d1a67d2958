#include "camera_option.hpp"

#include <charconv>
#include <cmath>
#include <system_error>
#include <vector>

#include "splitray/core/errors.hpp"

namespace splitray::cli {

std::string camera_problem(const std::string& text, CameraSpec& out) {
  std::vector<float> values;
  std::size_t begin = 0;
  while (begin <= text.size()) {
    std::size_t end = text.find(',', begin);
    if (end == std::string::npos) end = text.size();
    std::string field = text.substr(begin, end - begin);
    field.erase(0, field.find_first_not_of(' '));
    field.erase(field.find_last_not_of(' ') + 1);
    float value = 0;
    const char* first = field.data();
    const char* last = field.data() + field.size();
    if (!field.empty() && *first == '+') ++first;  // from_chars rejects a leading '+'
    const auto [ptr, ec] = std::from_chars(first, last, value);
    if (field.empty() || ec != std::errc{} || ptr != last || !std::isfinite(value))
      return "'" + field + "' is not a finite number (expected EX,EY,EZ,TX,TY,TZ[,FOV])";
    values.push_back(value);
    begin = end + 1;
  }
  if (values.size() != 6 && values.size() != 7)
    return "expected 6 or 7 comma-separated numbers EX,EY,EZ,TX,TY,TZ[,FOV], got " +
           std::to_string(values.size());
  out.eye = {values[0], values[1], values[2]};
  out.target = {values[3], values[4], values[5]};
  out.vfov_degrees.reset();
  if (values.size() == 7) {
    if (!(values[6] > 0 && values[6] < 180)) return "FOV must lie between 0 and 180 degrees";
    out.vfov_degrees = values[6];
  }
  if (out.eye == out.target) return "the eye and the target are the same point";
  Camera camera;
  camera.eye = out.eye;
  camera.target = out.target;
  return camera.problem();
}

CameraSpec parse_camera(const std::string& text, const std::string& option) {
  CameraSpec spec;
  const std::string problem = camera_problem(text, spec);
  if (!problem.empty()) throw Error(option, problem);
  return spec;
}

Camera to_camera(const CameraSpec& spec, float default_vfov) {
  Camera camera;
  camera.eye = spec.eye;
  camera.target = spec.target;
  camera.vfov_degrees = spec.vfov_degrees.value_or(default_vfov);
  const Vec3 forward = normalize(spec.target - spec.eye);
  if (length(cross(forward, camera.up)) < 1e-4f) camera.up = {0, 0, 1};  // looking straight up/down
  return camera;
}

CLI::Option* add_camera_option(CLI::App& command, std::string& text) {
  const CLI::Validator check(
      [](std::string& value) {
        CameraSpec spec;
        return camera_problem(value, spec);
      },
      "", "camera");
  return command
      .add_option("-c,--camera", text,
                  "Pinhole camera: eye EX,EY,EZ, target TX,TY,TZ and optional vertical FOV in "
                  "degrees (up is +y)")
      ->type_name("EX,EY,EZ,TX,TY,TZ[,FOV]")
      ->check(check);
}

}  // namespace splitray::cli

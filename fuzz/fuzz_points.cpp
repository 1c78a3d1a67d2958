// libFuzzer target: point files through load_points (knn's input): an input starting with
// "ply" as input.ply, anything else as XYZ text (input.xyz). Accepted points must be finite.
#include <cstring>

#include "fuzz_input.hpp"
#include "splitray/query/point_io.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const bool ply = size >= 3 && std::memcmp(data, "ply", 3) == 0;
  const std::string path = splitray::fuzz::write_input(data, size, ply ? "input.ply" : "input.xyz");
  try {
    if (!splitray::is_point_file(path)) return 0;  // a PLY with faces is a mesh (fuzz_ply)
    const std::vector<splitray::Vec3> points = splitray::load_points(path);
    for (std::size_t i = 0; i < points.size(); ++i)
      if (!splitray::fuzz::finite(points[i]))
        splitray::fuzz::finding("point " + std::to_string(i) + " is not finite");
  } catch (const splitray::Error&) {
  }
  return 0;
}

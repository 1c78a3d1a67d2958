// libFuzzer target for one mesh format (SPLITRAY_FUZZ_EXTENSION: obj, ply, stl, off, gltf, md2):
// the input as input.<extension> through load_scene, the path every command takes (the format
// check, assimp, materials and textures beside the file, triangulation, the mesh checks).
// gltf: an input with the binary magic "glTF" is named .glb. md2: also the animation path
// (FrameSequence, each keyframe imported on its own).
#include <cstring>
#include <string>

#include "fuzz_input.hpp"
#include "splitray/io/frames.hpp"
#include "splitray/io/load_scene.hpp"
#include "splitray/io/mesh_io.hpp"

namespace {

std::string input_name(const std::uint8_t* data, std::size_t size) {
  std::string extension = SPLITRAY_FUZZ_EXTENSION;
  if (extension == "gltf" && size >= 4 && std::memcmp(data, "glTF", 4) == 0) extension = "glb";
  return "input." + extension;
}

void check_frames(const std::string& path) {
  std::vector<std::vector<splitray::Triangle>> frames;
  try {
    frames = splitray::load_frames(splitray::FrameSequence({path}), 4);
  } catch (const splitray::Error&) {
    return;
  }
  for (std::size_t f = 0; f < frames.size(); ++f)
    for (const splitray::Triangle& t : frames[f])
      if (!splitray::fuzz::finite(t.v0) || !splitray::fuzz::finite(t.v1) ||
          !splitray::fuzz::finite(t.v2))
        splitray::fuzz::finding("animation frame " + std::to_string(f) +
                                " has a NaN or infinite coordinate");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = splitray::fuzz::write_input(data, size, input_name(data, size));
  try {
    splitray::fuzz::check_scene(splitray::load_scene(path));
  } catch (const splitray::Error&) {
  }
  if (std::string(SPLITRAY_FUZZ_EXTENSION) == "md2") check_frames(path);
  return 0;
}

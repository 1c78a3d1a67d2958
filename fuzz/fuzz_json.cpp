// libFuzzer target: JSON scene files through load_scene. The input is scene.json in a folder
// that also holds the meshes the seed scenes place (copies of tests/fixtures/cube.obj and
// quads.glb), so that mutations reach instances, transforms and materials, not only the parser.
#include <filesystem>

#include "fuzz_input.hpp"
#include "splitray/io/load_scene.hpp"
#include "splitray/io/mesh_io.hpp"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const std::filesystem::path fixtures =
      std::filesystem::path(SPLITRAY_SOURCE_DIR) / "tests/fixtures";
  for (const char* name : {"cube.obj", "quads.glb"})
    std::filesystem::copy_file(fixtures / name, splitray::fuzz::work_dir() / name,
                               std::filesystem::copy_options::overwrite_existing);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = splitray::fuzz::write_input(data, size, "scene.json");
  try {
    splitray::fuzz::check_scene(splitray::load_scene(path));
  } catch (const splitray::Error&) {
  }
  return 0;
}

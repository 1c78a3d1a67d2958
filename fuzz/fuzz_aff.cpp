// libFuzzer target: BART scenes (*.aff) through AffScene::load, then the scene at the
// animation's start, middle and end (key-framed transforms and animated triangles evaluated).
#include "fuzz_input.hpp"
#include "splitray/io/aff.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = splitray::fuzz::write_input(data, size, "input.aff");
  try {
    const splitray::AffScene aff = splitray::AffScene::load(path);
    const splitray::AffAnimation& a = aff.animation();
    const double start = a.frames > 0 ? a.start : 0.0, end = a.frames > 0 ? a.end : 0.0;
    for (const double t : {start, 0.5 * (start + end), end})
      splitray::fuzz::check_scene(aff.scene_at(t));
  } catch (const splitray::Error&) {
  }
  return 0;
}

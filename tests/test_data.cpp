#include "test_data.hpp"

#include <stb/stb_image.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

namespace splitray::test {

std::filesystem::path source_dir() { return SPLITRAY_SOURCE_DIR; }

std::filesystem::path shared_data_dir() {
  if (const char* env = std::getenv("SPLITRAY_SHARED_DATA")) return env;
  const auto dir = source_dir().parent_path() / "shared" / "data";
  return std::filesystem::is_directory(dir) ? dir : std::filesystem::path{};
}

std::string shared_file(const std::string& relative) {
  const auto dir = shared_data_dir();
  if (dir.empty()) return {};
  const auto path = dir / relative;
  return std::filesystem::exists(path) ? path.string() : std::string{};
}

std::string vendored_file(const std::string& relative) {
  return (source_dir() / "data" / relative).string();
}

std::filesystem::path temp_dir(const std::string& name) {
  const auto dir = std::filesystem::path(SPLITRAY_BINARY_DIR) / "test-tmp" / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string quote(const std::string& text) {
  std::string quoted = "'";
  for (const char c : text) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

Png read_png(const std::filesystem::path& path) {
  Png png;
  int channels = 0;
  unsigned char* data = stbi_load(path.string().c_str(), &png.width, &png.height, &channels, 3);
  if (!data) return png;
  png.rgb.assign(data, data + static_cast<std::size_t>(png.width) * png.height * 3);
  stbi_image_free(data);
  return png;
}

}  // namespace splitray::test

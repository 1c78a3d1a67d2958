#include "splitray/render/data_dir.hpp"

#include <cstdlib>
#include <filesystem>
#include <vector>

#include "splitray/core/errors.hpp"

namespace splitray {

namespace {

std::vector<std::filesystem::path> data_dirs() {
  std::vector<std::filesystem::path> dirs;
  if (const char* env = std::getenv("SPLITRAY_DATA_DIR"); env && *env) dirs.emplace_back(env);
#ifdef SPLITRAY_DEFAULT_DATA_DIR
  dirs.emplace_back(SPLITRAY_DEFAULT_DATA_DIR);
#endif
#ifdef SPLITRAY_INSTALL_DATA_DIR
  dirs.emplace_back(SPLITRAY_INSTALL_DATA_DIR);
#endif
  // A relocated install: <prefix>/bin/splitray next to <prefix>/share/splitray/data.
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) dirs.push_back(exe.parent_path().parent_path() / "share" / "splitray" / "data");
  return dirs;
}

}  // namespace

std::string find_data_file(const std::string& relative) {
  std::string looked;
  for (const auto& dir : data_dirs()) {
    const auto path = dir / relative;
    std::error_code ec;
    if (std::filesystem::is_regular_file(path, ec)) return path.string();
    looked += "\n  " + path.string();
  }
  throw Error(relative,
              "data file not found; set SPLITRAY_DATA_DIR to the folder holding it "
              "(looked in:" +
                  looked + ")");
}

}  // namespace splitray

#include "splitray/accel/neural/model_path.hpp"

#include <cstdlib>
#include <filesystem>

#include "splitray/core/errors.hpp"

namespace splitray {

namespace {

std::string model_file(NeuralCost cost) { return cost == NeuralCost::sah ? "sah.bin" : "vvh.bin"; }

}  // namespace

std::vector<std::string> model_dirs() {
  std::vector<std::string> dirs;
  if (const char* env = std::getenv("SPLITRAY_MODEL_DIR"); env && *env) dirs.emplace_back(env);
  // The source tree named as for scripts/ (io/plot_script.cpp): the tests set it, and it holds
  // where __FILE__ is relative (a compiler cache that rewrites paths).
  if (const char* env = std::getenv("SPLITRAY_SOURCE_DIR"); env && *env)
    dirs.push_back((std::filesystem::path(env) / "models").string());
  // This file is src/splitray/accel/neural/model_path.cpp: the source tree is four levels up.
  const std::filesystem::path self(__FILE__);
  if (self.is_absolute())
    dirs.push_back(
        (self.parent_path().parent_path().parent_path().parent_path().parent_path() / "models")
            .string());
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec)
    dirs.push_back((exe.parent_path().parent_path() / "share" / "splitray" / "models").string());
  return dirs;
}

std::string find_default_model(NeuralCost cost) {
  for (const std::string& dir : model_dirs()) {
    const std::filesystem::path p = std::filesystem::path(dir) / model_file(cost);
    std::error_code ec;
    if (std::filesystem::is_regular_file(p, ec)) return p.string();
  }
  return {};
}

std::string default_model_path(NeuralCost cost) {
  std::string found = find_default_model(cost);
  if (!found.empty()) return found;
  std::string looked;
  for (const std::string& dir : model_dirs()) looked += (looked.empty() ? "" : ", ") + dir;
  throw Error("--model", "no " + model_file(cost) + " found (looked in: " + looked +
                             "); train one with `splitray train` or pass --model FILE");
}

}  // namespace splitray

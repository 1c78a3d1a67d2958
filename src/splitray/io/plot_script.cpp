#include "splitray/io/plot_script.hpp"

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <vector>

#include "splitray/core/errors.hpp"
#include "splitray/core/output_file.hpp"

namespace splitray {

namespace fs = std::filesystem;

std::string find_plot_script(const std::string& name) {
  std::vector<fs::path> roots;
  if (const char* env = std::getenv("SPLITRAY_SOURCE_DIR")) roots.emplace_back(env);
  std::error_code ec;
  fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  for (int up = 0; !ec && up < 4 && exe.has_parent_path(); ++up) {
    exe = exe.parent_path();
    roots.push_back(exe);
  }
  roots.push_back(fs::current_path());
  for (const fs::path& root : roots)
    if (fs::exists(root / "scripts" / name)) return (root / "scripts" / name).string();
  throw Error("--plot",
              "scripts/" + name + " not found (set SPLITRAY_SOURCE_DIR to the source tree)");
}

void run_plot_script(const std::string& name, const std::string& png, const std::string& data) {
  const std::string script = find_plot_script(name);
  // The temporary keeps the .png ending: matplotlib picks the format from it.
  TemporaryFile tmp(png, ".png");
  const auto quoted = [](const std::string& s) {
    std::string q = "'";
    for (const char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return q + "'";
  };
  const std::string command =
      "/usr/bin/python3 " + quoted(script) + " --out " + quoted(tmp.name()) + " " + quoted(data);
  if (std::system(command.c_str()) != 0)
    throw Error("--plot " + png, "the plotting script " + script + " failed");
  tmp.commit();
}

}  // namespace splitray

#pragma once
// The plotting scripts of the source tree's scripts/ folder (Python with matplotlib, Debian's
// /usr/bin/python3 and python3-matplotlib): found beside the source tree and run on a data file
// to draw a PNG, which appears whole or not at all.
#include <string>

namespace splitray {

// The path of scripts/NAME: under $SPLITRAY_SOURCE_DIR, a folder above the executable, or the
// working folder. Throws Error("--plot", ...) when it is in none of them.
std::string find_plot_script(const std::string& name);

// Runs scripts/NAME --out PNG DATA... and renames the picture into place only when the script
// succeeds. Throws Error("--plot PNG", ...) when it fails.
void run_plot_script(const std::string& name, const std::string& png, const std::string& data);

}  // namespace splitray

#pragma once
// Where the tests find real data: the vendored meshes under data/ (always there) and
// ../shared/data beside the checkout (skipped with a message when absent).
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <vector>

namespace splitray::test {

std::filesystem::path source_dir();
// ../shared/data, or SPLITRAY_SHARED_DATA if set; empty if absent.
std::filesystem::path shared_data_dir();
// The path of a file under shared data, or "" if shared data or the file is absent.
std::string shared_file(const std::string& relative);
std::string vendored_file(const std::string& relative);  // under data/
// A fresh temporary folder for one test.
std::filesystem::path temp_dir(const std::string& name);
// The whole file as bytes (empty when it cannot be read).
std::string read_text(const std::filesystem::path& path);
// TEXT in single quotes for /bin/sh.
std::string quote(const std::string& text);

// A PNG decoded to 8-bit RGB rows (width and height 0 when it cannot be read).
struct Png {
  int width = 0, height = 0;
  std::vector<unsigned char> rgb;
};
Png read_png(const std::filesystem::path& path);

}  // namespace splitray::test

// Skips the current test, naming what is missing, when a shared data file is absent.
#define SPLITRAY_REQUIRE_SHARED(var, relative)                     \
  const std::string var = ::splitray::test::shared_file(relative); \
  if (var.empty()) GTEST_SKIP() << "shared data file " << (relative) << " is absent; skipped"

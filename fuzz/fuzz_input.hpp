#pragma once
// Shared by the libFuzzer targets: the fuzz input as a file with the name the loader dispatches
// on, and the oracles. A loader may throw splitray::Error (bad input, said clearly); any other
// exception escapes LLVMFuzzerTestOneInput and aborts (a finding), as do crashes, leaks and UB
// (ASan, UBSan). What a loader accepts must be a valid scene: finite coordinates, indices in
// range; check_scene aborts otherwise, naming the problem.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>

#include "splitray/core/errors.hpp"
#include "splitray/core/scene.hpp"

namespace splitray::fuzz {

// A private folder for this process's input files, removed at a normal exit.
inline const std::filesystem::path& work_dir() {
  static const std::filesystem::path dir = [] {
    std::string pattern =
        (std::filesystem::temp_directory_path() / "splitray-fuzz-XXXXXX").string();
    if (!mkdtemp(pattern.data())) {
      std::perror("mkdtemp");
      std::abort();
    }
    std::atexit([] {
      std::error_code ignored;
      std::filesystem::remove_all(work_dir(), ignored);
    });
    return std::filesystem::path(pattern);
  }();
  return dir;
}

// Writes `bytes` to work_dir()/name (replacing it) and returns its path.
inline std::string write_file(std::span<const unsigned char> bytes, const std::string& name) {
  const std::filesystem::path path = work_dir() / name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
  out.close();
  if (!out) {
    std::fprintf(stderr, "fuzz: cannot write %s\n", path.c_str());
    std::abort();
  }
  return path.string();
}

inline std::string write_input(const std::uint8_t* data, std::size_t size,
                               const std::string& name) {
  return write_file({data, size}, name);
}

[[noreturn]] inline void finding(const std::string& what) {
  std::fprintf(stderr, "fuzz finding: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

inline bool finite(const Vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// What a successful load promises: Scene::validate passes and the world-space triangles (every
// instance's transform applied) have finite coordinates.
inline void check_scene(const Scene& scene) {
  try {
    scene.validate("loaded scene");
  } catch (const Error& e) {
    finding(std::string("the loader accepted an invalid scene: ") + e.what());
  }
  const FlatScene flat = flatten(scene);
  for (std::size_t i = 0; i < flat.triangles.size(); ++i) {
    const Triangle& t = flat.triangles[i];
    if (!finite(t.v0) || !finite(t.v1) || !finite(t.v2))
      finding("the loader accepted a scene whose world-space triangle " + std::to_string(i) +
              " has a NaN or infinite coordinate");
  }
}

}  // namespace splitray::fuzz

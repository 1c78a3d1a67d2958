#pragma once
// Float RGB image (linear radiance) with PNG output.
#include <string>
#include <vector>

#include "splitray/core/vec.hpp"

namespace splitray {

struct Image {
  int width = 0, height = 0;
  std::vector<Vec3> pixels;  // row-major, top row first

  Image() = default;
  Image(int w, int h) : width(w), height(h), pixels(static_cast<std::size_t>(w) * h) {}
  Vec3& at(int x, int y) { return pixels[static_cast<std::size_t>(y) * width + x]; }
  const Vec3& at(int x, int y) const { return pixels[static_cast<std::size_t>(y) * width + x]; }

  // 8-bit sRGB (clamped), row-major RGB triplets.
  std::vector<unsigned char> to_srgb8() const;
};

// Writes the image as PNG through a temporary file renamed into place, so that a failed
// write leaves no partial file. Throws Error(path, ...) on failure.
void write_png(const std::string& path, const Image& image);

// Writes bytes to `path` atomically (temporary file in the same folder, then rename).
void write_file_atomically(const std::string& path, const std::string& bytes);

}  // namespace splitray

#include "splitray/core/image.hpp"

#include <stb/stb_image_write.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "splitray/core/errors.hpp"

namespace splitray {

namespace {

unsigned char encode_srgb(float linear) {
  if (!(linear > 0)) return 0;  // also NaN
  if (linear >= 1) return 255;
  const float s = linear <= 0.0031308f ? 12.92f * linear : 1.055f * std::pow(linear, 1 / 2.4f) - 0.055f;
  return static_cast<unsigned char>(std::lround(s * 255.0f));
}

std::string temporary_name(const std::string& path) {
  return path + ".tmp." + std::to_string(::getpid());
}

void rename_into_place(const std::string& tmp, const std::string& path) {
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw Error(path, "cannot write the file (rename failed)");
  }
}

}  // namespace

std::vector<unsigned char> Image::to_srgb8() const {
  std::vector<unsigned char> out(pixels.size() * 3);
  for (std::size_t i = 0; i < pixels.size(); ++i)
    for (int c = 0; c < 3; ++c) out[i * 3 + c] = encode_srgb(pixels[i][c]);
  return out;
}

void write_png(const std::string& path, const Image& image) {
  if (image.width <= 0 || image.height <= 0) throw Error(path, "cannot write an empty image");
  const std::vector<unsigned char> bytes = image.to_srgb8();
  const std::string tmp = temporary_name(path);
  if (!stbi_write_png(tmp.c_str(), image.width, image.height, 3, bytes.data(), image.width * 3)) {
    std::error_code ec;
    std::filesystem::remove(tmp, ec);
    throw Error(path, "cannot write the PNG file (does the folder exist and is it writable?)");
  }
  rename_into_place(tmp, path);
}

void write_file_atomically(const std::string& path, const std::string& bytes) {
  const std::string tmp = temporary_name(path);
  {
    std::ofstream out(tmp, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) {
      std::error_code ec;
      std::filesystem::remove(tmp, ec);
      throw Error(path, "cannot write the file (does the folder exist and is it writable?)");
    }
  }
  rename_into_place(tmp, path);
}

}  // namespace splitray

#include "splitray/core/image.hpp"

#include <Imath/half.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfOutputFile.h>
#include <stb/stb_image_write.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

#include "splitray/core/errors.hpp"

namespace splitray {

namespace {

unsigned char encode_srgb(float linear) {
  if (!(linear > 0)) return 0;  // also NaN
  if (linear >= 1) return 255;
  const float s =
      linear <= 0.0031308f ? 12.92f * linear : 1.055f * std::pow(linear, 1 / 2.4f) - 0.055f;
  return static_cast<unsigned char>(std::lround(s * 255.0f));
}

}  // namespace

std::vector<unsigned char> Image::to_srgb8() const {
  std::vector<unsigned char> out(pixels.size() * 3);
  for (std::size_t i = 0; i < pixels.size(); ++i)
    for (int c = 0; c < 3; ++c) out[i * 3 + c] = encode_srgb(pixels[i][c]);
  return out;
}

std::string encode_png(const Image& image, const std::string& where) {
  if (image.width <= 0 || image.height <= 0) throw Error(where, "cannot write an empty image");
  const std::vector<unsigned char> bytes = image.to_srgb8();
  std::string png;
  const auto append = [](void* context, void* data, int size) {
    static_cast<std::string*>(context)->append(static_cast<const char*>(data),
                                               static_cast<std::size_t>(size));
  };
  if (!stbi_write_png_to_func(append, &png, image.width, image.height, 3, bytes.data(),
                              image.width * 3))
    throw Error(where, "cannot encode the PNG image");
  return png;
}

void write_png(const std::string& path, const Image& image) {
  // Encoded in memory, then written like every other output (core/output_file.hpp).
  write_file_atomically(path, encode_png(image, path));
}

ImageFormat check_image_path(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  ImageFormat format;
  if (extension == ".png")
    format = ImageFormat::png;
  else if (extension == ".exr")
    format = ImageFormat::exr;
  else if (extension == ".pfm")
    format = ImageFormat::pfm;
  else
    throw Error(path, (extension.empty() ? std::string("no extension")
                                         : "unknown image format '" + extension + "'") +
                          ": use .png (8-bit sRGB), .exr (OpenEXR, linear half or float) or "
                          ".pfm (portable float map, linear)");
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code error;
  if (!parent.empty() && !std::filesystem::is_directory(parent, error))
    throw Error(path, "cannot write: folder " + parent.string() + " does not exist");
  if (std::filesystem::is_directory(path, error)) throw Error(path, "cannot write: it is a folder");
  check_output_file(path);
  return format;
}

namespace {

// OpenEXR through its own writer (scanlines, ZIP compression) into the temporary file.
void write_exr(const std::string& path, const Image& image, bool full_float) {
  TemporaryFile tmp(path);
  try {
    const Imf::PixelType type = full_float ? Imf::FLOAT : Imf::HALF;
    Imf::Header header(image.width, image.height);
    for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(type));
    Imf::OutputFile file(tmp.name().c_str(), header);
    Imf::FrameBuffer buffer;
    std::vector<Imath::half> halves;  // the pixels rounded to half, when the channels are half
    const char* base = reinterpret_cast<const char*>(image.pixels.data());
    std::size_t pixel = sizeof(Vec3), component = sizeof(float);
    if (!full_float) {
      for (const Vec3& p : image.pixels) halves.insert(halves.end(), {p.x, p.y, p.z});
      base = reinterpret_cast<const char*>(halves.data());
      pixel = 3 * sizeof(Imath::half);
      component = sizeof(Imath::half);
    }
    const std::size_t row = pixel * static_cast<std::size_t>(image.width);
    for (int c = 0; c < 3; ++c)
      buffer.insert(std::string(1, "RGB"[c]),
                    Imf::Slice(type, const_cast<char*>(base + c * component), pixel, row));
    file.setFrameBuffer(buffer);
    file.writePixels(image.height);
  } catch (const std::exception& e) {
    throw Error(path, std::string("cannot write the OpenEXR file: ") + e.what());
  }
  tmp.commit();
}

// PFM: "PF", width and height, a negative scale for little-endian, then float RGB rows from
// the bottom row up.
std::string pfm_bytes(const Image& image) {
  std::string out =
      "PF\n" + std::to_string(image.width) + " " + std::to_string(image.height) + "\n-1.0\n";
  const std::size_t header = out.size();
  out.resize(header + image.pixels.size() * 12);
  char* p = out.data() + header;
  for (int y = image.height - 1; y >= 0; --y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) {
        std::uint32_t bits = std::bit_cast<std::uint32_t>(image.at(x, y)[c]);
        if constexpr (std::endian::native == std::endian::big) bits = __builtin_bswap32(bits);
        std::memcpy(p, &bits, 4);
        p += 4;
      }
  return out;
}

}  // namespace

void write_image(const std::string& path, const Image& image, const ImageWriteOptions& options) {
  const ImageFormat format = check_image_path(path);
  if (image.width <= 0 || image.height <= 0) throw Error(path, "cannot write an empty image");
  switch (format) {
    case ImageFormat::png:
      return write_png(path, image);
    case ImageFormat::exr:
      return write_exr(path, image, options.exr_float);
    case ImageFormat::pfm:
      return write_file_atomically(path, pfm_bytes(image));
  }
}

double psnr_db(const Image& a, const Image& b) {
  if (a.width != b.width || a.height != b.height) throw Error("psnr", "images differ in size");
  const auto x = a.to_srgb8(), y = b.to_srgb8();
  double sum = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double d = static_cast<double>(x[i]) - y[i];
    sum += d * d;
  }
  if (sum == 0) return INFINITY;
  const double mse = sum / static_cast<double>(x.size());
  return 10 * std::log10(255.0 * 255.0 / mse);
}

}  // namespace splitray

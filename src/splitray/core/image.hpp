#pragma once
// Float RGB image (linear radiance) with PNG, OpenEXR and PFM output, chosen by extension.
#include <string>
#include <string_view>
#include <vector>

#include "splitray/core/output_file.hpp"  // write_file_atomically
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
// The bytes write_png writes (8-bit sRGB PNG), for a program that encodes where it renders and
// writes elsewhere (mpirun animate: every rank encodes its own frames). `where` names the image.
std::string encode_png(const Image& image, const std::string& where);

// The image files splitray writes, by extension (any case): .png 8-bit sRGB (clamped),
// .exr OpenEXR with linear RGB as half (default) or 32-bit float channels, .pfm the portable
// float map (linear 32-bit float RGB, little-endian, rows bottom to top).
enum class ImageFormat { png, exr, pfm };
struct ImageWriteOptions {
  bool exr_float = false;  // .exr: 32-bit float channels instead of half
};
// The format of `path`, or Error(path, ...) naming the formats when its extension is none of
// them; also an Error when its folder does not exist or it is a folder. Meant to be called
// before any work, so that a bad output name fails at once and writes nothing.
ImageFormat check_image_path(const std::string& path);
// Writes `image` in the format of its extension, atomically as write_png.
void write_image(const std::string& path, const Image& image,
                 const ImageWriteOptions& options = {});

// PSNR in dB of two images of the same size over their 8-bit sRGB values (inf if equal).
double psnr_db(const Image& a, const Image& b);

}  // namespace splitray

#pragma once
// Image textures decoded by stb_image (PNG, JPEG, BMP, TGA, PSD, GIF, HDR, PNM): 8-bit images
// are taken as sRGB and turned into linear RGB, HDR images are linear already.
#include <memory>
#include <span>
#include <string>

#include "splitray/core/texture.hpp"

namespace splitray {

// Largest texture accepted, per side.
inline constexpr int kMaxTextureSize = 16384;

// Throws Error(name, ...) when the bytes are not an image stb_image decodes, or too large.
std::shared_ptr<Texture> decode_texture(std::span<const unsigned char> bytes,
                                        const std::string& name);
// read_file + decode_texture.
std::shared_ptr<Texture> load_texture(const std::string& path);

}  // namespace splitray

#include "splitray/io/texture_io.hpp"

#include <stb/stb_image.h>

#include <array>
#include <cmath>
#include <limits>

#include "splitray/core/errors.hpp"
#include "splitray/io/read_file.hpp"

namespace splitray {

namespace {

float srgb_to_linear(float s) {
  return s <= 0.04045f ? s / 12.92f : std::pow((s + 0.055f) / 1.055f, 2.4f);
}

const std::array<float, 256>& srgb_table() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) t[i] = srgb_to_linear(static_cast<float>(i) / 255.0f);
    return t;
  }();
  return table;
}

}  // namespace

std::shared_ptr<Texture> decode_texture(std::span<const unsigned char> bytes,
                                        const std::string& name) {
  if (bytes.empty()) throw Error(name, "the texture is empty");
  if (bytes.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    throw Error(name, "the texture file is too large");
  const int size = static_cast<int>(bytes.size());
  int w = 0, h = 0, channels = 0;
  if (!stbi_info_from_memory(bytes.data(), size, &w, &h, &channels))
    throw Error(name, std::string("not an image stb_image reads: ") + stbi_failure_reason());
  if (w <= 0 || h <= 0 || w > kMaxTextureSize || h > kMaxTextureSize)
    throw Error(name, "the texture is " + std::to_string(w) + " x " + std::to_string(h) +
                          " pixels (at most " + std::to_string(kMaxTextureSize) + " per side)");
  auto texture = std::make_shared<Texture>();
  texture->name = name;
  const std::size_t n = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  if (stbi_is_hdr_from_memory(bytes.data(), size)) {
    float* data = stbi_loadf_from_memory(bytes.data(), size, &w, &h, &channels, 3);
    if (!data) throw Error(name, std::string("cannot decode the image: ") + stbi_failure_reason());
    texture->texels.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      texture->texels[i] = {data[3 * i], data[3 * i + 1], data[3 * i + 2]};
    stbi_image_free(data);
  } else {
    unsigned char* data = stbi_load_from_memory(bytes.data(), size, &w, &h, &channels, 3);
    if (!data) throw Error(name, std::string("cannot decode the image: ") + stbi_failure_reason());
    const auto& table = srgb_table();
    texture->texels.resize(n);
    for (std::size_t i = 0; i < n; ++i)
      texture->texels[i] = {table[data[3 * i]], table[data[3 * i + 1]], table[data[3 * i + 2]]};
    stbi_image_free(data);
  }
  texture->width = w;
  texture->height = h;
  return texture;
}

std::shared_ptr<Texture> load_texture(const std::string& path) {
  const Bytes bytes = read_file(path, std::size_t{1} << 30);
  return decode_texture(bytes, path);
}

}  // namespace splitray

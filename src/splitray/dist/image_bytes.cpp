#include "splitray/dist/image_bytes.hpp"

#include <cstdint>
#include <cstring>

#include "splitray/core/errors.hpp"

namespace splitray::dist {

std::string image_to_bytes(const Image& image) {
  const std::int32_t size[2] = {image.width, image.height};
  std::string bytes(sizeof size + image.pixels.size() * sizeof(Vec3), '\0');
  std::memcpy(bytes.data(), size, sizeof size);
  std::memcpy(bytes.data() + sizeof size, image.pixels.data(), image.pixels.size() * sizeof(Vec3));
  return bytes;
}

Image image_from_bytes(std::string_view bytes, const std::string& what) {
  std::int32_t size[2] = {0, 0};
  if (bytes.size() < sizeof size) throw Error("result of " + what, "too short for an image");
  std::memcpy(size, bytes.data(), sizeof size);
  if (size[0] <= 0 || size[1] <= 0 ||
      bytes.size() != sizeof size + static_cast<std::size_t>(size[0]) * size[1] * sizeof(Vec3))
    throw Error("result of " + what, "not an image of the size it claims");
  Image image(size[0], size[1]);
  std::memcpy(image.pixels.data(), bytes.data() + sizeof size, image.pixels.size() * sizeof(Vec3));
  return image;
}

}  // namespace splitray::dist

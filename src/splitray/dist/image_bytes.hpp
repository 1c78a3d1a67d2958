#pragma once
// Images as the bytes of a work-queue result: width, height and the float pixels, exactly.
#include <string>
#include <string_view>

#include "splitray/core/image.hpp"

namespace splitray::dist {

std::string image_to_bytes(const Image& image);
// Throws Error("result of `what`", ...) when the bytes are not an image.
Image image_from_bytes(std::string_view bytes, const std::string& what);

}  // namespace splitray::dist

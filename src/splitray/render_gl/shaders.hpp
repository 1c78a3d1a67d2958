#pragma once
// The GLSL sources of shaders/*.glsl, embedded at build time (embed_shaders.cmake).
#include <string_view>

namespace splitray::gl {

// The text of shaders/NAME; throws Error for an unknown name.
std::string_view shader_source(std::string_view name);

}  // namespace splitray::gl

#pragma once
// Image textures in linear RGB, sampled bilinearly with the wrap mode of each axis, the same
// arithmetic as the hybrid renderer's shaders (render_gl/shaders/texture.glsl).
#include <cstdint>
#include <string>
#include <vector>

#include "splitray/core/vec.hpp"

namespace splitray {

// Texture coordinates: u left to right, v bottom to top (OpenGL's and OBJ's convention;
// assimp turns glTF's top-left origin into it).
struct Vec2 {
  float x = 0, y = 0;
  constexpr bool operator==(const Vec2&) const = default;
};

enum class WrapMode : std::uint8_t { repeat, clamp, mirror };

struct Texture {
  std::string name;  // the file (or embedded texture) it came from
  int width = 0, height = 0;
  std::vector<Vec3> texels;  // linear RGB, row-major, top row first
  WrapMode wrap_u = WrapMode::repeat, wrap_v = WrapMode::repeat;

  const Vec3& at(int x, int y) const {
    return texels[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                  static_cast<std::size_t>(x)];
  }
  // Bilinear between the four texels around `uv` (texel centres at (i + 0.5) / size).
  Vec3 sample(Vec2 uv) const;
};

}  // namespace splitray

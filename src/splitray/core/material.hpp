#pragma once
// Surface materials in the Phong model that both renderers shade with (render/shading.hpp and
// render_gl's composite shader). How each file format's materials map onto it: io/materials.cpp
// and the README's "Materials and textures".
#include <memory>
#include <optional>
#include <string>

#include "splitray/core/texture.hpp"
#include "splitray/core/vec.hpp"

namespace splitray {

struct Material {
  std::string name = "default";
  Vec3 diffuse{0.8f};
  Vec3 specular{0.0f};
  float shininess = 32;
  float reflectivity = 0;  // share of light from the mirror direction
  float transparency = 0;  // share of light refracted through the surface
  float ior = 1.5f;        // index of refraction inside the surface
  bool fresnel = false;    // weight reflection and refraction by Schlick's Fresnel term
  // What the scene's ambient light reflects; without it the diffuse colour (the usual case:
  // only BART's materials give one).
  std::optional<Vec3> ambient;
  // Multiplies `diffuse` at the hit's texture coordinates (shared between materials that use
  // one image).
  std::shared_ptr<const Texture> diffuse_texture;

  // The diffuse colour at texture coordinates `uv`.
  Vec3 diffuse_at(Vec2 uv) const {
    return diffuse_texture ? diffuse * diffuse_texture->sample(uv) : diffuse;
  }
};

}  // namespace splitray

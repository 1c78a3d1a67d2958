#include "splitray/io/materials.hpp"

#include <assimp/GltfMaterial.h>
#include <assimp/ObjMaterial.h>
#include <assimp/material.h>
#include <assimp/scene.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "splitray/core/errors.hpp"
#include "splitray/io/read_file.hpp"
#include "splitray/io/texture_io.hpp"

namespace splitray {

namespace {

bool get_color(const aiMaterial& m, const char* key, unsigned type, unsigned index, Vec3& out) {
  aiColor4D c;
  if (m.Get(key, type, index, c) != AI_SUCCESS) return false;
  if (!std::isfinite(c.r) || !std::isfinite(c.g) || !std::isfinite(c.b)) return false;
  out = {std::max(c.r, 0.0f), std::max(c.g, 0.0f), std::max(c.b, 0.0f)};
  return true;
}

bool get_float(const aiMaterial& m, const char* key, unsigned type, unsigned index, float& out) {
  float v = 0;
  if (m.Get(key, type, index, v) != AI_SUCCESS || !std::isfinite(v)) return false;
  out = v;
  return true;
}

WrapMode wrap_mode(int mode) {
  switch (mode) {
    case aiTextureMapMode_Clamp:
    case aiTextureMapMode_Decal:
      return WrapMode::clamp;
    case aiTextureMapMode_Mirror:
      return WrapMode::mirror;
    default:
      return WrapMode::repeat;
  }
}

class TextureCache {
 public:
  TextureCache(const aiScene& scene, std::string folder, std::string root, std::string file,
               std::vector<std::string>& warnings)
      : scene_(scene),
        folder_(std::move(folder)),
        root_(std::move(root)),
        file_(std::move(file)),
        warnings_(warnings) {}

  // The texture of `type` (index 0) of `m` with its wrap modes, or null (with a warning when
  // the material names one that cannot be read).
  std::shared_ptr<const Texture> get(const aiMaterial& m, aiTextureType type) {
    aiString path;
    if (m.GetTexture(type, 0, &path) != AI_SUCCESS || path.length == 0) return nullptr;
    int wrap_u = aiTextureMapMode_Wrap, wrap_v = aiTextureMapMode_Wrap;
    m.Get(AI_MATKEY_MAPPINGMODE_U(type, 0), wrap_u);
    m.Get(AI_MATKEY_MAPPINGMODE_V(type, 0), wrap_v);
    const std::shared_ptr<Texture> image = image_of(path.C_Str(), m.GetName().C_Str());
    if (!image) return nullptr;
    const WrapMode u = wrap_mode(wrap_u), v = wrap_mode(wrap_v);
    if (image->wrap_u == u && image->wrap_v == v) return image;
    // The same image with other wrap modes: a texture of its own (texels shared by copy).
    auto copy = std::make_shared<Texture>(*image);
    copy->wrap_u = u;
    copy->wrap_v = v;
    return copy;
  }

 private:
  std::shared_ptr<Texture> image_of(const std::string& reference, const std::string& material) {
    if (const auto it = images_.find(reference); it != images_.end()) return it->second;
    std::shared_ptr<Texture> image;
    try {
      image = decode(reference);
    } catch (const Error& e) {
      warnings_.push_back(file_ + ": material '" + material + "': texture " + e.what() +
                          "; rendered without it");
    }
    images_[reference] = image;
    return image;
  }

  std::shared_ptr<Texture> decode(const std::string& reference) {
    if (const aiTexture* embedded = scene_.GetEmbeddedTexture(reference.c_str())) {
      const std::string name = file_ + " (embedded texture " + reference + ")";
      if (embedded->mHeight == 0) {  // compressed (PNG, JPEG, ...): mWidth bytes
        const auto* data = reinterpret_cast<const unsigned char*>(embedded->pcData);
        return decode_texture({data, embedded->mWidth}, name);
      }
      auto texture = std::make_shared<Texture>();  // raw BGRA texels, top row first
      texture->name = name;
      texture->width = static_cast<int>(embedded->mWidth);
      texture->height = static_cast<int>(embedded->mHeight);
      if (texture->width > kMaxTextureSize || texture->height > kMaxTextureSize)
        throw Error(name, "is too large");
      for (std::size_t i = 0; i < std::size_t{embedded->mWidth} * embedded->mHeight; ++i) {
        const aiTexel& t = embedded->pcData[i];
        const auto linear = [](unsigned char c) {
          const float s = static_cast<float>(c) / 255.0f;
          return s <= 0.04045f ? s / 12.92f : std::pow((s + 0.055f) / 1.055f, 2.4f);
        };
        texture->texels.push_back({linear(t.r), linear(t.g), linear(t.b)});
      }
      return texture;
    }
    std::string relative = reference;
    std::replace(relative.begin(), relative.end(), '\\', '/');
    const std::string path =
        (std::filesystem::path(folder_) / relative).lexically_normal().string();
    // A material may not make us read any image of the machine (map_Kd ../../secret.png).
    if (!inside_folder(root_, path))
      throw Error(path, "lies outside the folder of the model; refusing to read it");
    return load_texture(path);
  }

  const aiScene& scene_;
  std::string folder_, root_, file_;
  std::vector<std::string>& warnings_;
  std::map<std::string, std::shared_ptr<Texture>> images_;
};

// glTF 2.0's metallic-roughness in the Phong model (the mapping of materials.hpp).
void metallic_roughness(const aiMaterial& m, Material& out, TextureCache& textures) {
  Vec3 base{1};
  get_color(m, AI_MATKEY_BASE_COLOR, base);
  float metallic = 1, roughness = 1;
  get_float(m, AI_MATKEY_METALLIC_FACTOR, metallic);
  get_float(m, AI_MATKEY_ROUGHNESS_FACTOR, roughness);
  metallic = std::clamp(metallic, 0.0f, 1.0f);
  roughness = std::clamp(roughness, 0.0f, 1.0f);
  out.diffuse = base * (1 - metallic);
  out.specular = Vec3{0.04f} * (1 - metallic) + base * metallic;
  const float alpha = std::max(roughness * roughness, 0.02f);
  out.shininess = std::max(2 / (alpha * alpha) - 2, 1.0f);
  out.reflectivity = metallic * (1 - roughness) * (1 - roughness);
  out.diffuse_texture = textures.get(m, aiTextureType_BASE_COLOR);
  if (!out.diffuse_texture) out.diffuse_texture = textures.get(m, aiTextureType_DIFFUSE);
  aiString mode;
  aiColor4D base_alpha;
  if (m.Get(AI_MATKEY_GLTF_ALPHAMODE, mode) == AI_SUCCESS && std::string(mode.C_Str()) == "BLEND" &&
      m.Get(AI_MATKEY_BASE_COLOR, base_alpha) == AI_SUCCESS && base_alpha.a < 1) {
    out.transparency = std::clamp(1 - base_alpha.a, 0.0f, 1.0f);
    out.ior = 1;
  }
}

// OBJ's illumination models (MTL's illum), on a material read with the common keys.
void obj_illum(int illum, const Vec3& ks, Material& out) {
  const float strength = max_component(ks);
  if (illum <= 1) out.specular = Vec3{0};
  if (illum == 3 || illum == 8 || illum == 4 || illum == 5 || illum == 6 || illum == 7)
    out.reflectivity = std::clamp(strength, 0.0f, 1.0f);
  if (illum == 5 || illum == 7) out.fresnel = true;
  const bool glass = illum == 4 || illum == 6 || illum == 7 || illum == 9;
  if (!glass && out.transparency > 0) out.ior = 1;  // dissolve: see-through without bending
}

Material convert(const aiMaterial& m, TextureCache& textures) {
  Material out;
  out.name = m.GetName().length > 0 ? m.GetName().C_Str() : "unnamed";
  float metallic = 0;
  if (get_float(m, AI_MATKEY_METALLIC_FACTOR, metallic)) {
    metallic_roughness(m, out, textures);
  } else {
    get_color(m, AI_MATKEY_COLOR_DIFFUSE, out.diffuse);
    Vec3 ks{0};
    if (get_color(m, AI_MATKEY_COLOR_SPECULAR, ks)) {
      float strength = 1;
      get_float(m, AI_MATKEY_SHININESS_STRENGTH, strength);
      out.specular = ks * std::max(strength, 0.0f);
    }
    float shininess = 0;
    if (get_float(m, AI_MATKEY_SHININESS, shininess))
      out.shininess = std::clamp(shininess, 1.0f, 1e6f);
    float opacity = 1;
    if (get_float(m, AI_MATKEY_OPACITY, opacity) && opacity < 1)
      out.transparency = std::clamp(1 - opacity, 0.0f, 1.0f);
    float ior = 0;
    if (get_float(m, AI_MATKEY_REFRACTI, ior) && ior >= 1e-3f && ior <= 100) out.ior = ior;
    float reflectivity = 0;
    Vec3 reflective{0};
    if (get_float(m, AI_MATKEY_REFLECTIVITY, reflectivity) &&
        get_color(m, AI_MATKEY_COLOR_REFLECTIVE, reflective))
      out.reflectivity = std::clamp(reflectivity * max_component(reflective), 0.0f, 1.0f);
    int illum = -1;
    if (m.Get(AI_MATKEY_OBJ_ILLUM, illum) == AI_SUCCESS) obj_illum(illum, ks, out);
    out.diffuse_texture = textures.get(m, aiTextureType_DIFFUSE);
  }
  // Energy: the mirror and refracted shares come out of the diffuse share (shading.hpp).
  if (out.reflectivity + out.transparency > 1) out.reflectivity = 1 - out.transparency;
  return out;
}

}  // namespace

std::vector<Material> convert_materials(const aiScene& scene, const std::string& folder,
                                        const std::string& root, const std::string& file,
                                        std::vector<std::string>& warnings) {
  TextureCache textures(scene, folder, root, file, warnings);
  std::vector<Material> out;
  for (unsigned i = 0; i < scene.mNumMaterials; ++i)
    out.push_back(convert(*scene.mMaterials[i], textures));
  return out;
}

}  // namespace splitray

#pragma once
// assimp's materials as splitray's Phong materials (core/material.hpp). One mapping for every
// format assimp reads, from assimp's material keys:
//   - OBJ/MTL: Kd diffuse, Ks specular, Ns shininess, d (or 1 - Tr) opacity, Ni index of
//     refraction, illum: 0-1 no highlight, 3 and 8 mirror reflection of Ks's strength, 4, 6, 7
//     and 9 refraction with Ni (glass), 5 and 7 Fresnel-weighted; d < 1 elsewhere is
//     see-through without bending (ior 1); map_Kd the diffuse texture (-clamp on: clamped).
//   - glTF 2.0 metallic-roughness, approximated in the Phong model: diffuse = base colour
//     (factor x texture) x (1 - metallic), specular = 0.04 mixed towards the base colour by
//     metallic, shininess = 2 / alpha^2 - 2 with alpha = roughness^2 (Blinn-Phong's lobe of
//     the same width), reflectivity = metallic x (1 - roughness)^2; alphaMode BLEND makes
//     1 - alpha see-through.
//   - COLLADA and the other formats: diffuse, specular (x shininess strength), shininess,
//     opacity, index of refraction, reflectivity x reflective colour, the diffuse texture.
// Textures come from the file's folder (backslashes read as slashes) or embedded in the file
// (GLB, "*N"); one that lies outside `root` is not read (a warning, as a missing one); wrap modes
// from the file (repeat, clamp, mirror; decal is clamped). A texture that is missing or unreadable
// is a warning, and the material is rendered untextured.
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "splitray/core/material.hpp"

struct aiScene;

namespace splitray {

// Every material of `scene` in assimp's order; `folder` is where relative texture paths
// resolve, `root` the folder textures must lie in, `file` names the mesh file in warnings.
std::vector<Material> convert_materials(const aiScene& scene, const std::string& folder,
                                        const std::string& root, const std::string& file,
                                        std::vector<std::string>& warnings);

}  // namespace splitray

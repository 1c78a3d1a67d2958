#pragma once
// A scene: meshes, instances of them with transforms and materials, lights and a camera.
#include <optional>
#include <string>
#include <vector>

#include "splitray/core/camera.hpp"
#include "splitray/core/mesh.hpp"
#include "splitray/core/transform.hpp"

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
};

struct Light {
  enum class Kind { point, directional };
  Kind kind = Kind::point;
  Vec3 position{0, 10, 0};    // point lights
  Vec3 direction{0, -1, 0};   // directional lights: the direction light travels
  Vec3 color{1.0f};
  float intensity = 1;        // point lights: radiant intensity, falls off with 1/d^2
};

struct Instance {
  std::uint32_t mesh = 0;
  Transform transform;
  std::uint32_t material = 0;
};

struct Scene {
  std::vector<Mesh> meshes;
  std::vector<Material> materials{Material{}};
  std::vector<Instance> instances;
  std::vector<Light> lights;
  std::optional<Camera> camera;
  Vec3 background{0.05f, 0.05f, 0.08f};
  Vec3 ambient{0.08f};

  Aabb bounds() const;
  // Throws Error(where, ...) on out-of-range mesh or material indices, empty scenes, bad meshes.
  void validate(const std::string& where) const;
};

// The scene in world space as one triangle soup, the input of every hierarchy.
struct FlatScene {
  std::vector<Triangle> triangles;
  std::vector<std::uint32_t> material;               // per triangle
  std::vector<std::array<Vec3, 3>> vertex_normals;   // per triangle, world space, normalised
};

FlatScene flatten(const Scene& scene);

// A scene of one mesh (grey diffuse), a light above-behind the camera and a framed camera.
Scene scene_from_mesh(Mesh mesh);

}  // namespace splitray

#pragma once
// A scene: meshes, instances of them with transforms and materials, lights and a camera.
#include <optional>
#include <string>
#include <vector>

#include "splitray/core/camera.hpp"
#include "splitray/core/material.hpp"
#include "splitray/core/mesh.hpp"
#include "splitray/core/transform.hpp"

namespace splitray {

struct Light {
  enum class Kind { point, directional };
  Kind kind = Kind::point;
  Vec3 position{0, 10, 0};    // point lights
  Vec3 direction{0, -1, 0};   // directional lights: the direction light travels
  Vec3 color{1.0f};
  float intensity = 1;        // point lights: radiant intensity, falls off with 1/d^2
  bool falloff = true;        // point lights: false = no 1/d^2 (NFF's and BART's lights)
};

struct Instance {
  std::uint32_t mesh = 0;
  Transform transform;
  // One material (index into Scene::materials) for every face of the mesh; without it the
  // faces keep the mesh's own materials, or Scene::materials[0] where the mesh has none.
  std::optional<std::uint32_t> material;
};

struct Scene {
  std::vector<Mesh> meshes;
  std::vector<Material> materials{Material{}};
  std::vector<Instance> instances;
  std::vector<Light> lights;
  // No lights of its own (a bare mesh, a JSON scene without "lights"): the commands give it
  // lights that fit the camera (render/view_lights.hpp) once the camera is known.
  bool lights_fit_view = false;
  std::optional<Camera> camera;
  Vec3 background{0.05f, 0.05f, 0.08f};
  Vec3 ambient{0.08f};
  std::vector<std::string> warnings;  // from loading: problems that did not stop it

  Aabb bounds() const;
  // Throws Error(where, ...) on out-of-range mesh or material indices, empty scenes, bad meshes.
  void validate(const std::string& where) const;
};

// The scene in world space as one triangle soup, the input of every hierarchy.
struct FlatScene {
  std::vector<Triangle> triangles;
  // Scene::materials followed by every mesh's own materials, and each triangle's index.
  std::vector<Material> materials;
  std::vector<std::uint32_t> material;               // per triangle
  std::vector<std::array<Vec3, 3>> vertex_normals;   // per triangle, world space, normalised
  std::vector<std::array<Vec2, 3>> uvs;              // per triangle; zero where a mesh has none
};

FlatScene flatten(const Scene& scene);

// A scene of one mesh (its own materials, else grey diffuse), a framed camera, and lights
// that fit the view (lights_fit_view).
Scene scene_from_mesh(Mesh mesh);

}  // namespace splitray

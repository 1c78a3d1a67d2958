#include "splitray/core/scene.hpp"

#include "splitray/core/coordinates.hpp"
#include "splitray/core/errors.hpp"

namespace splitray {

Aabb Scene::bounds() const {
  Aabb b;
  for (const Instance& inst : instances)
    for (const Vec3& p : meshes[inst.mesh].positions) b.extend(inst.transform.point(p));
  return b;
}

void Scene::validate(const std::string& where) const {
  if (instances.empty()) throw Error(where, "the scene has no mesh instances");
  if (materials.empty()) throw Error(where, "the scene has no materials");
  for (std::size_t i = 0; i < instances.size(); ++i) {
    if (instances[i].mesh >= meshes.size())
      throw Error(where, "instance " + std::to_string(i) + " names mesh " +
                             std::to_string(instances[i].mesh) + " of " +
                             std::to_string(meshes.size()));
    if (instances[i].material && *instances[i].material >= materials.size())
      throw Error(where, "instance " + std::to_string(i) + " names material " +
                             std::to_string(*instances[i].material) + " of " +
                             std::to_string(materials.size()));
  }
  for (const Mesh& mesh : meshes) mesh.validate(where + " (mesh '" + mesh.name + "')");
  // Transforms may move valid vertices beyond the limit (or overflow them to inf).
  for (std::size_t i = 0; i < instances.size(); ++i) {
    const Mesh& mesh = meshes[instances[i].mesh];
    for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
      const Vec3 p = instances[i].transform.point(mesh.positions[v]);
      if (!within_coordinate_limit(p))
        throw Error(where, "the transform of instance " + std::to_string(i) + " (mesh '" +
                               mesh.name + "') moves vertex " + std::to_string(v) + " to " +
                               coordinate_problem(p));
    }
  }
  if (camera)
    if (const std::string problem = camera->problem(); !problem.empty())
      throw Error(where, "camera: " + problem);
}

FlatScene flatten(const Scene& scene) {
  FlatScene flat;
  flat.materials = scene.materials;
  std::vector<std::uint32_t> first_material;  // of each mesh's own materials in flat.materials
  for (const Mesh& mesh : scene.meshes) {
    first_material.push_back(static_cast<std::uint32_t>(flat.materials.size()));
    flat.materials.insert(flat.materials.end(), mesh.materials.begin(), mesh.materials.end());
  }
  for (const Instance& inst : scene.instances) {
    const Mesh& mesh = scene.meshes[inst.mesh];
    for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
      const auto& idx = mesh.faces[f];
      Triangle tri{inst.transform.point(mesh.positions[idx[0]]),
                   inst.transform.point(mesh.positions[idx[1]]),
                   inst.transform.point(mesh.positions[idx[2]])};
      std::array<Vec3, 3> normals;
      std::array<Vec2, 3> uvs{};
      const Vec3 geometric = normalize(tri.geometric_normal());
      for (int k = 0; k < 3; ++k)
        normals[k] = mesh.normals.empty() ? geometric : inst.transform.normal(mesh.normals[idx[k]]);
      if (!mesh.uvs.empty())
        for (int k = 0; k < 3; ++k) uvs[k] = mesh.uvs[idx[k]];
      flat.triangles.push_back(tri);
      flat.material.push_back(inst.material ? *inst.material
                              : mesh.materials.empty()
                                  ? 0
                                  : first_material[inst.mesh] + mesh.face_materials[f]);
      flat.vertex_normals.push_back(normals);
      flat.uvs.push_back(uvs);
    }
  }
  return flat;
}

Scene scene_from_mesh(Mesh mesh) {
  Scene scene;
  const Aabb box = mesh.bounds();
  scene.meshes.push_back(std::move(mesh));
  scene.instances.push_back(Instance{});
  scene.camera = Camera::frame(box);
  scene.lights_fit_view = true;
  return scene;
}

}  // namespace splitray

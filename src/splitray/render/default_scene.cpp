#include "splitray/render/default_scene.hpp"

#include "splitray/io/mesh_io.hpp"
#include "splitray/render/data_dir.hpp"
#include "splitray/render/shapes.hpp"

namespace splitray {

namespace {

std::uint32_t add_material(Scene& scene, Material m) {
  scene.materials.push_back(std::move(m));
  return static_cast<std::uint32_t>(scene.materials.size() - 1);
}

void add(Scene& scene, Mesh mesh, std::uint32_t material, const Transform& transform = {}) {
  scene.meshes.push_back(std::move(mesh));
  scene.instances.push_back(
      Instance{static_cast<std::uint32_t>(scene.meshes.size() - 1), transform, material});
}

Material diffuse(const std::string& name, const Vec3& color) {
  Material m;
  m.name = name;
  m.diffuse = color;
  return m;
}

}  // namespace

Scene default_scene() {
  Scene scene;
  scene.materials.clear();
  scene.background = Vec3{0.20f, 0.24f, 0.32f};
  scene.ambient = Vec3{0.06f};

  // The room: x in [-4, 4], y in [0, 5], z in [-6, 2]; open at z = 2, where the camera stands.
  const float x0 = -4, x1 = 4, y1 = 5, z0 = -6, z1 = 2;
  const auto white = add_material(scene, diffuse("white wall", Vec3{0.73f}));
  const auto red = add_material(scene, diffuse("red wall", Vec3{0.63f, 0.065f, 0.05f}));
  const auto green = add_material(scene, diffuse("green wall", Vec3{0.14f, 0.45f, 0.09f}));
  const auto tile_light =
      add_material(scene, diffuse("light floor tile", Vec3{0.78f, 0.76f, 0.72f}));
  const auto tile_dark = add_material(scene, diffuse("dark floor tile", Vec3{0.25f, 0.25f, 0.28f}));
  const Vec3 floor_origin{x0, 0, z1}, along_x{x1 - x0, 0, 0}, along_z{0, 0, z0 - z1};
  add(scene, make_checker(floor_origin, along_x, along_z, 8, 0), tile_light);
  add(scene, make_checker(floor_origin, along_x, along_z, 8, 1), tile_dark);
  add(scene, make_quad({x0, y1, z0}, along_x, {0, 0, z1 - z0}), white);    // ceiling
  add(scene, make_quad({x0, 0, z0}, along_x, {0, y1, 0}), white);          // back wall
  add(scene, make_quad({x0, 0, z1}, {0, 0, z0 - z1}, {0, y1, 0}), red);    // left wall
  add(scene, make_quad({x1, 0, z0}, {0, 0, z1 - z0}, {0, y1, 0}), green);  // right wall

  // The Stanford dragon, gold-coloured Phong, standing on the floor at the back.
  Material gold = diffuse("dragon", Vec3{0.78f, 0.45f, 0.12f});
  gold.specular = Vec3{0.5f, 0.45f, 0.35f};
  gold.shininess = 40;
  gold.reflectivity = 0.1f;
  Mesh dragon = load_mesh(find_data_file("dragon_100k/dragon.obj.gz"));
  if (dragon.normals.empty()) dragon.compute_vertex_normals();
  const Aabb db = dragon.bounds();
  const float dragon_scale = 3.6f / db.extent().x;  // 3.6 units long
  add(scene, std::move(dragon), add_material(scene, gold),
      Transform::translate({0.4f, 0, -3.9f}) * Transform::rotate({0, 1, 0}, -20) *
          Transform::scale(Vec3{dragon_scale}) *
          Transform::translate({-db.center().x, -db.lo.y, -db.center().z}));

  // A mirror sphere on the left and a glass sphere on the right, in front of the dragon.
  Material mirror = diffuse("mirror", Vec3{0.05f});
  mirror.specular = Vec3{0.8f};
  mirror.shininess = 200;
  mirror.reflectivity = 0.9f;
  const float mirror_radius = 0.95f;
  add(scene, make_icosphere(5), add_material(scene, mirror),
      Transform::translate({-2.0f, mirror_radius, -2.5f}) * Transform::scale(Vec3{mirror_radius}));
  Material glass = diffuse("glass", Vec3{0.05f});
  glass.specular = Vec3{0.9f};
  glass.shininess = 300;
  glass.transparency = 0.9f;
  glass.ior = 1.5f;
  glass.fresnel = true;
  const float glass_radius = 0.75f;
  add(scene, make_icosphere(5), add_material(scene, glass),
      Transform::translate({1.55f, glass_radius, -1.5f}) * Transform::scale(Vec3{glass_radius}));

  // A warm point light under the ceiling and cool daylight through the open front.
  Light lamp;
  lamp.kind = Light::Kind::point;
  lamp.position = {0.0f, 4.6f, -1.8f};
  lamp.color = {1.0f, 0.93f, 0.82f};
  lamp.intensity = 14;
  scene.lights.push_back(lamp);
  Light daylight;
  daylight.kind = Light::Kind::directional;
  daylight.direction = normalize(Vec3{-0.35f, -0.55f, -1.0f});
  daylight.color = {0.75f, 0.82f, 1.0f};
  daylight.intensity = 0.35f;
  scene.lights.push_back(daylight);

  Camera camera;
  camera.eye = {0.0f, 2.3f, 1.9f};
  camera.target = {0.0f, 1.1f, -3.0f};
  camera.vfov_degrees = 55;
  scene.camera = camera;
  scene.validate("default scene");
  return scene;
}

}  // namespace splitray

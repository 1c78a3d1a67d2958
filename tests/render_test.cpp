// The Whitted renderer: same image for every thread count, shadows, mirrors, refraction,
// ray counts, progress, errors; the generated shapes and the built-in default scene.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <numbers>

#include "splitray/core/errors.hpp"
#include "splitray/render/data_dir.hpp"
#include "splitray/render/default_scene.hpp"
#include "splitray/render/shapes.hpp"
#include "splitray/render/whitted.hpp"
#include "test_data.hpp"

namespace splitray {
namespace {

std::uint32_t add_material(Scene& scene, const Material& m) {
  scene.materials.push_back(m);
  return static_cast<std::uint32_t>(scene.materials.size() - 1);
}

void add(Scene& scene, Mesh mesh, std::uint32_t material, const Transform& transform = {}) {
  scene.meshes.push_back(std::move(mesh));
  scene.instances.push_back(
      {static_cast<std::uint32_t>(scene.meshes.size() - 1), transform, material});
}

Material matte(const Vec3& color) {
  Material m;
  m.diffuse = color;
  return m;
}

Light point_light(const Vec3& position, float intensity) {
  Light l;
  l.kind = Light::Kind::point;
  l.position = position;
  l.intensity = intensity;
  return l;
}

// The pixel (column, row) of `camera` that sees world point p: Camera::generate inverted.
std::pair<int, int> pixel_of(const Camera& camera, int width, int height, const Vec3& p) {
  const Vec3 forward = normalize(camera.target - camera.eye);
  const Vec3 right = normalize(cross(forward, camera.up));
  const Vec3 up = cross(right, forward);
  const float tan_half = std::tan(camera.vfov_degrees * std::numbers::pi_v<float> / 360.0f);
  const float aspect = static_cast<float>(width) / static_cast<float>(height);
  const Vec3 d = p - camera.eye;
  const float sx = dot(d, right) / dot(d, forward), sy = dot(d, up) / dot(d, forward);
  const float x = (sx / (tan_half * aspect) + 1) * 0.5f * static_cast<float>(width);
  const float y = (1 - sy / tan_half) * 0.5f * static_cast<float>(height);
  return {static_cast<int>(std::floor(x)), static_cast<int>(std::floor(y))};
}

float luminance(const Vec3& c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

RenderOptions small_options(int width, int height) {
  RenderOptions o;
  o.width = width;
  o.height = height;
  o.accel = "brute";  // the renderer is under test here, not the structure
  return o;
}

// A small room with everything the renderer does: two lights, shadows, a mirror sphere,
// a glass sphere (Fresnel) and a box.
Scene feature_scene() {
  Scene scene;
  scene.materials = {matte(Vec3{0.7f})};
  add(scene, make_checker({-3, 0, 3}, {6, 0, 0}, {0, 0, -6}, 4, 0), 0);
  add(scene, make_checker({-3, 0, 3}, {6, 0, 0}, {0, 0, -6}, 4, 1),
      add_material(scene, matte({0.2f, 0.2f, 0.6f})));
  add(scene, make_quad({-3, 0, -3}, {6, 0, 0}, {0, 4, 0}),
      add_material(scene, matte({0.7f, 0.2f, 0.1f})));
  Material mirror = matte(Vec3{0.05f});
  mirror.reflectivity = 0.9f;
  mirror.specular = Vec3{0.5f};
  add(scene, make_icosphere(2), add_material(scene, mirror),
      Transform::translate({-1.2f, 0.8f, -1}) * Transform::scale(Vec3{0.8f}));
  Material glass = matte(Vec3{0.05f});
  glass.transparency = 0.9f;
  glass.fresnel = true;
  glass.specular = Vec3{0.8f};
  glass.shininess = 100;
  add(scene, make_icosphere(2), add_material(scene, glass),
      Transform::translate({1.0f, 0.7f, 0.2f}) * Transform::scale(Vec3{0.7f}));
  add(scene, make_box({-0.3f, 0, -2}, {0.5f, 1.5f, -1.2f}), 0);
  scene.lights.push_back(point_light({0.5f, 3.5f, 1.0f}, 10));
  Light sun;
  sun.kind = Light::Kind::directional;
  sun.direction = {-0.3f, -1, -0.5f};
  sun.intensity = 0.4f;
  scene.lights.push_back(sun);
  Camera camera;
  camera.eye = {0, 2, 5};
  camera.target = {0, 0.7f, -1};
  scene.camera = camera;
  return scene;
}

TEST(Whitted, ImageIsBitIdenticalForOneAndTwoThreads) {
  const Scene scene = feature_scene();
  RenderOptions one = small_options(64, 48), two = one;
  one.build.threads = 1;
  two.build.threads = 2;
  const RenderResult a = render_whitted(scene, *scene.camera, one);
  const RenderResult b = render_whitted(scene, *scene.camera, two);
  ASSERT_EQ(a.image.pixels.size(), 64u * 48u);
  ASSERT_EQ(b.image.pixels.size(), a.image.pixels.size());
  EXPECT_EQ(std::memcmp(a.image.pixels.data(), b.image.pixels.data(),
                        a.image.pixels.size() * sizeof(Vec3)),
            0);
  EXPECT_EQ(a.rays, b.rays);
  // The scene exercises secondary and shadow rays, far more than one ray per pixel.
  EXPECT_GT(a.rays, 3u * 64u * 48u);
  for (const Vec3& p : a.image.pixels) ASSERT_TRUE(is_finite(p));
}

TEST(Whitted, KdStructureGivesTheSameImageAsBruteForce) {
  const Scene scene = feature_scene();
  RenderOptions brute = small_options(48, 36), kd = brute;
  kd.accel = "kd";
  const RenderResult a = render_whitted(scene, *scene.camera, brute);
  const RenderResult b = render_whitted(scene, *scene.camera, kd);
  EXPECT_EQ(b.accel_stats.accel, "kd");
  EXPECT_EQ(std::memcmp(a.image.pixels.data(), b.image.pixels.data(),
                        a.image.pixels.size() * sizeof(Vec3)),
            0);
  EXPECT_EQ(a.rays, b.rays);
}

TEST(Whitted, PixelInShadowIsDarkerThanLitPixel) {
  Scene scene;
  scene.materials = {matte(Vec3{0.8f})};
  add(scene, make_quad({-5, 0, 5}, {10, 0, 0}, {0, 0, -10}), 0);      // floor
  add(scene, make_box({-0.5f, 1.0f, -0.5f}, {0.5f, 1.2f, 0.5f}), 0);  // occluder over the origin
  scene.lights.push_back(point_light({0, 4, 0}, 16));
  Camera camera;
  camera.eye = {0, 3, 6};
  camera.target = {0, 0, 0};
  const int w = 64, h = 48;
  const RenderResult r = render_whitted(scene, camera, small_options(w, h));
  const auto [sx, sy] = pixel_of(camera, w, h, {0, 0, 0});
  const auto [lx, ly] = pixel_of(camera, w, h, {2.5f, 0, 0});
  const Vec3 shadowed = r.image.at(sx, sy), lit = r.image.at(lx, ly);
  // In the shadow only the ambient term remains.
  EXPECT_NEAR(shadowed.x, scene.ambient.x * 0.8f, 1e-5f);
  EXPECT_GT(luminance(lit), 4 * luminance(shadowed));
  // Irradiance of the lit point: I cos(theta) / d^2 (Phong diffuse, no 1/pi).
  const Vec3 to_light = Vec3{0, 4, 0} - Vec3{2.5f, 0, 0};
  const float expected = 0.8f * 16 * (4 / length(to_light)) / dot(to_light, to_light);
  EXPECT_NEAR(lit.x - scene.ambient.x * 0.8f, expected, 0.1f * expected);  // pixel ~ the point
}

TEST(Whitted, MirrorShowsTheColourOfTheObjectItFaces) {
  Scene scene;
  Material mirror = matte(Vec3{0});
  mirror.reflectivity = 1;
  scene.materials = {mirror, matte({0.9f, 0.05f, 0.05f})};
  scene.background = Vec3{0};
  scene.ambient = Vec3{0};
  add(scene, make_quad({-3, -3, -2}, {6, 0, 0}, {0, 6, 0}), 0);  // mirror at z = -2 facing +z
  add(scene, make_quad({3, -3, 8}, {-6, 0, 0}, {0, 6, 0}), 1);   // red wall behind the camera
  scene.lights.push_back(point_light({0, 0, 6}, 10));
  Camera camera;
  camera.eye = {0, 0, 5};
  camera.target = {0, 0, 0};
  RenderOptions options = small_options(32, 24);
  const Vec3 seen = render_whitted(scene, camera, options).image.at(16, 12);
  EXPECT_GT(seen.x, 0.1f);
  EXPECT_GT(seen.x, 5 * seen.y);
  EXPECT_GT(seen.x, 5 * seen.z);
  // The mirror itself is black: without bounces nothing is seen in it.
  options.max_depth = 0;
  EXPECT_EQ(render_whitted(scene, camera, options).image.at(16, 12), Vec3{0});
}

// A glass ball in front of a wall that is red on the left, blue on the right.
Scene lens_scene(float ior) {
  Scene scene;
  Material glass = matte(Vec3{0});
  glass.transparency = 1;
  glass.ior = ior;
  scene.materials = {matte({0.9f, 0.05f, 0.05f}), matte({0.05f, 0.05f, 0.9f}), glass};
  scene.background = Vec3{0.3f, 0.4f, 0.5f};
  add(scene, make_quad({-20, -20, -5}, {20, 0, 0}, {0, 40, 0}), 0);
  add(scene, make_quad({0, -20, -5}, {20, 0, 0}, {0, 40, 0}), 1);
  add(scene, make_icosphere(3), 2);
  Light sun;
  sun.kind = Light::Kind::directional;
  sun.direction = {0, 0, -1};
  scene.lights.push_back(sun);
  return scene;
}

TEST(Whitted, RefractionThroughGlassInvertsTheImageAndLeavesNoHoles) {
  Camera camera;
  camera.eye = {0, 0, 5};
  camera.target = {0, 0, 0};
  camera.vfov_degrees = 30;
  const int w = 64, h = 48;
  const RenderOptions options = small_options(w, h);
  // A point left of the ball's centre, inside its silhouette.
  const auto [x, y] = pixel_of(camera, w, h, {-0.3f, 0, 1});
  const RenderResult glass = render_whitted(lens_scene(1.5f), camera, options);
  const RenderResult air = render_whitted(lens_scene(1.0f), camera, options);
  EXPECT_GT(glass.image.at(x, y).z, 5 * glass.image.at(x, y).x) << "a ball lens inverts the wall";
  EXPECT_GT(air.image.at(x, y).x, 5 * air.image.at(x, y).z) << "ior 1 bends nothing";
  for (const Vec3& p : glass.image.pixels) {
    ASSERT_TRUE(is_finite(p));
    EXPECT_GT(luminance(p), 0.01f) << "a black hole in the glass";
  }
}

TEST(Whitted, CountsEveryRay) {
  Scene scene;
  scene.materials = {matte(Vec3{0.5f})};
  add(scene, make_quad({-50, -50, 0}, {100, 0, 0}, {0, 100, 0}), 0);
  Camera camera;
  camera.eye = {0, 0, 5};
  camera.target = {0, 0, 0};
  const RenderOptions options = small_options(20, 10);
  EXPECT_EQ(render_whitted(scene, camera, options).rays, 200u);  // primary only
  scene.lights.push_back(point_light({0, 0, 3}, 1));
  EXPECT_EQ(render_whitted(scene, camera, options).rays, 400u);  // + one shadow ray each
}

TEST(Whitted, ReportsProgressUpToOne) {
  const Scene scene = feature_scene();
  RenderOptions options = small_options(40, 20);
  std::vector<double> reported;
  options.progress = [&](double done) { reported.push_back(done); };  // one thread at a time
  render_whitted(scene, *scene.camera, options);
  ASSERT_EQ(reported.size(), 3u * 2u);  // 16x16 tiles
  for (std::size_t i = 1; i < reported.size(); ++i) EXPECT_GT(reported[i], reported[i - 1]);
  EXPECT_DOUBLE_EQ(reported.back(), 1.0);
}

TEST(Whitted, RejectsBadOptions) {
  const Scene scene = feature_scene();
  RenderOptions options = small_options(0, 10);
  EXPECT_THROW(render_whitted(scene, *scene.camera, options), Error);
  options = small_options(10, 10);
  options.max_depth = -1;
  EXPECT_THROW(render_whitted(scene, *scene.camera, options), Error);
  options = small_options(10, 10);
  options.accel = "no-such-structure";
  EXPECT_THROW(render_whitted(scene, *scene.camera, options), Error);
}

TEST(Shapes, IcosphereIsAClosedUnitSphereWoundOutwards) {
  for (int level = 0; level <= 3; ++level) {
    const Mesh sphere = make_icosphere(level);
    EXPECT_EQ(sphere.faces.size(), 20u << (2 * level));
    EXPECT_EQ(sphere.positions.size(), 10u * (1u << (2 * level)) + 2u);  // Euler: V = F / 2 + 2
    for (const Vec3& p : sphere.positions) EXPECT_NEAR(length(p), 1.0f, 1e-6f);
    for (std::size_t f = 0; f < sphere.faces.size(); ++f) {
      const Triangle t = sphere.triangle(f);
      EXPECT_GT(dot(t.geometric_normal(), t.v0 + t.v1 + t.v2), 0) << "face " << f;
    }
  }
  EXPECT_THROW(make_icosphere(-1), Error);
}

TEST(Shapes, BoxAndCheckerFacesPointTheRightWay) {
  const Mesh box = make_box({-1, -2, -3}, {1, 2, 3});
  ASSERT_EQ(box.faces.size(), 12u);
  for (std::size_t f = 0; f < box.faces.size(); ++f) {
    const Triangle t = box.triangle(f);
    EXPECT_GT(dot(t.geometric_normal(), t.v0 + t.v1 + t.v2), 0) << "face " << f;
  }
  const Mesh even = make_checker({0, 0, 0}, {4, 0, 0}, {0, 0, -4}, 4, 0);
  const Mesh odd = make_checker({0, 0, 0}, {4, 0, 0}, {0, 0, -4}, 4, 1);
  EXPECT_EQ(even.faces.size(), 16u);
  EXPECT_EQ(odd.faces.size(), 16u);
  for (std::size_t f = 0; f < even.faces.size(); ++f)
    EXPECT_GT(even.triangle(f).geometric_normal().y, 0);
}

TEST(DataDir, MissingFileNamesTheEnvironmentVariable) {
  try {
    find_data_file("no/such/file.obj");
    FAIL() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("SPLITRAY_DATA_DIR"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("no/such/file.obj"), std::string::npos);
  }
  EXPECT_FALSE(find_data_file("dragon_100k/dragon.obj.gz").empty());
}

TEST(DefaultScene, HasTheRoomTheDragonGlassAndMirror) {
  const Scene scene = default_scene();
  ASSERT_TRUE(scene.camera.has_value());
  EXPECT_GE(scene.lights.size(), 1u);
  const FlatScene flat = flatten(scene);
  EXPECT_GT(flat.triangles.size(), 100000u);  // the dragon alone has 100k
  bool glass = false, mirror = false;
  for (const Material& m : scene.materials) {
    glass = glass || (m.transparency > 0.5f && m.ior > 1 && m.fresnel);
    mirror = mirror || m.reflectivity > 0.5f;
  }
  EXPECT_TRUE(glass);
  EXPECT_TRUE(mirror);
  // The camera is inside the room's bounds.
  EXPECT_TRUE(scene.bounds().contains(scene.camera->eye));
}

TEST(DefaultScene, RendersWithoutHolesAtLowResolution) {
  const Scene scene = default_scene();
  RenderOptions options;
  options.width = 80;
  options.height = 60;
  const RenderResult r = render_whitted(scene, *scene.camera, options);
  int background = 0;
  for (const Vec3& p : r.image.pixels) {
    ASSERT_TRUE(is_finite(p));
    background += p == scene.background;
  }
  EXPECT_LT(background, 80 * 60 / 20) << "the camera should look into the room";
  EXPECT_GT(r.rays, 2u * 80u * 60u);
}

}  // namespace
}  // namespace splitray

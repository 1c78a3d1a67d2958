// The hybrid GPU + CPU renderer (issue 8) against the CPU reference, headless through EGL
// (Mesa's llvmpipe where there is no GPU). Skipped with a message when EGL cannot start.
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <memory>

#include "splitray/core/errors.hpp"
#include "splitray/render/shapes.hpp"
#include "splitray/render_gl/cpu_pass.hpp"
#include "splitray/render_gl/gl_context.hpp"
#include "splitray/render_gl/hybrid.hpp"

namespace splitray {
namespace {

// A floor, a diffuse box, a mirror sphere and a glass sphere under a point light and a
// directional light: every pass has work, and it renders in well under a second.
Scene small_scene() {
  Scene s;
  s.materials.clear();
  Material floor;
  floor.diffuse = Vec3{0.7f, 0.7f, 0.65f};
  Material box;
  box.diffuse = Vec3{0.6f, 0.2f, 0.1f};
  box.specular = Vec3{0.3f};
  Material mirror;
  mirror.diffuse = Vec3{0.05f};
  mirror.specular = Vec3{0.8f};
  mirror.shininess = 100;
  mirror.reflectivity = 0.85f;
  Material glass;
  glass.diffuse = Vec3{0.05f};
  glass.transparency = 0.9f;
  glass.fresnel = true;
  s.materials = {floor, box, mirror, glass};
  const auto add = [&](Mesh m, std::uint32_t material, const Transform& t = {}) {
    s.meshes.push_back(std::move(m));
    s.instances.push_back({static_cast<std::uint32_t>(s.meshes.size() - 1), t, material});
  };
  add(make_quad({-4, 0, 3}, {8, 0, 0}, {0, 0, -8}), 0);
  add(make_box({-1.8f, 0, -1.5f}, {-0.6f, 1.2f, -0.3f}), 1);
  add(make_icosphere(3), 2, Transform::translate({0.9f, 0.8f, -1.0f}) * Transform::scale(Vec3{0.8f}));
  add(make_icosphere(3), 3, Transform::translate({-0.2f, 0.5f, 0.9f}) * Transform::scale(Vec3{0.5f}));
  Light lamp;
  lamp.position = {1.5f, 4.0f, 2.0f};
  lamp.intensity = 18;
  Light sun;
  sun.kind = Light::Kind::directional;
  sun.direction = normalize(Vec3{-0.4f, -1.0f, -0.5f});
  sun.intensity = 0.4f;
  s.lights = {lamp, sun};
  Camera c;
  c.eye = {0.5f, 2.6f, 5.0f};
  c.target = {0, 0.5f, -0.5f};
  c.vfov_degrees = 50;
  s.camera = c;
  return s;
}

HybridOptions small_options() {
  HybridOptions o;
  o.width = 160;
  o.height = 120;
  o.max_depth = 3;
  o.shadow_map_size = 1024;
  if (std::getenv("SPLITRAY_HYBRID_UNIFORM")) o.lispsm = false;
  return o;
}

class HybridTest : public ::testing::Test {
 protected:
  void SetUp() override {
    try {
      context_ = std::make_unique<gl::EglContext>();
    } catch (const Error& e) {
      GTEST_SKIP() << "no usable headless OpenGL: " << e.what();
    }
  }
  std::unique_ptr<gl::EglContext> context_;
};

TEST_F(HybridTest, AgreesWithWhitted) {
  const Scene scene = small_scene();
  const HybridOptions o = small_options();
  HybridRenderer renderer(scene, o, *scene.camera);
  const HybridFrame frame = renderer.render_one(*scene.camera);
  RenderOptions w;
  w.width = o.width;
  w.height = o.height;
  w.max_depth = o.max_depth;
  const RenderResult reference = render_whitted(scene, *scene.camera, w);
  const double psnr = psnr_db(frame.image, reference.image);
  if (std::getenv("SPLITRAY_HYBRID_DUMP")) {  // for looking at a failure
    write_png("hybrid_test_hybrid.png", frame.image);
    write_png("hybrid_test_whitted.png", reference.image);
    Image mask(o.width, o.height);
    for (std::size_t i = 0; i < mask.pixels.size(); ++i)
      mask.pixels[i] = Vec3{frame.mask[i][0], frame.mask[i][1], frame.refined[i][0]};
    write_png("hybrid_test_mask.png", mask);
  }
  std::printf("hybrid vs whitted: %.2f dB, cpu rays %llu of %llu\n", psnr,
              static_cast<unsigned long long>(frame.cpu_rays),
              static_cast<unsigned long long>(reference.rays));
  EXPECT_GE(psnr, 33.0);
  EXPECT_GT(frame.secondary_pixels, 0u);
  EXPECT_GT(frame.boundary_pixels, 0u);
  EXPECT_LT(frame.cpu_rays, reference.rays / 2);  // the GPU took the primary and most shadow rays
}

TEST_F(HybridTest, IdsMatchCpuPrimaryHits) {
  const Scene scene = small_scene();
  const HybridOptions o = small_options();
  HybridRenderer renderer(scene, o, *scene.camera);
  const HybridFrame frame = renderer.render_one(*scene.camera);
  const FlatScene flat = flatten(scene);
  const auto accel = make_accel("kd", flat.triangles);
  std::size_t same = 0, total = 0, background_mismatch = 0;
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      const Hit hit = accel->intersect(scene.camera->generate(x + 0.5f, y + 0.5f, o.width, o.height));
      const std::uint32_t expected = hit.found() ? hit.prim + 1 : 0;
      const std::uint32_t got = frame.ids[static_cast<std::size_t>(y) * o.width + x];
      ++total;
      same += got == expected;
      background_mismatch += (got == 0) != (expected == 0);
    }
  EXPECT_GE(static_cast<double>(same) / total, 0.97);
  EXPECT_LE(background_mismatch, total / 200);
}

TEST_F(HybridTest, RefinementFixesShadowMapErrors) {
  const Scene scene = small_scene();
  HybridOptions o = small_options();
  o.shadow_map_size = 256;  // coarse: many wrong pixels for the refinement to fix
  HybridRenderer renderer(scene, o, *scene.camera);
  const HybridFrame frame = renderer.render_one(*scene.camera);
  const FlatScene flat = flatten(scene);
  const auto accel = make_accel("kd", flat.triangles);
  gl::CpuPass exact(scene, flat, renderer.lights(), *accel, 0);
  std::size_t wrong_raw = 0, wrong_refined = 0;
  std::size_t wrong_raw_light[kMaxHybridLights] = {}, wrong_refined_light[kMaxHybridLights] = {};
  std::uint64_t rays = 0;
  Image wrong(o.width, o.height);  // red: the shadow map is wrong, green: still wrong refined
  for (int y = 0; y < o.height; ++y)
    for (int x = 0; x < o.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * o.width + x;
      if (frame.ids[i] == 0) continue;
      for (std::size_t l = 0; l < scene.lights.size(); ++l) {
        const float v = exact.exact_visibility(*scene.camera, o.width, o.height, x, y,
                                               frame.ids[i] - 1, static_cast<int>(l), rays);
        const bool raw_bad = (frame.mask[i][l] > 0.5f) != (v > 0.5f);
        const bool refined_bad = (frame.refined[i][l] > 0.5f) != (v > 0.5f);
        wrong_raw += raw_bad;
        wrong_refined += refined_bad;
        wrong_raw_light[l] += raw_bad;
        wrong_refined_light[l] += refined_bad;
        if (raw_bad) wrong.pixels[i].x = 1;
        if (refined_bad) wrong.pixels[i].y = 1;
      }
    }
  if (std::getenv("SPLITRAY_HYBRID_DUMP")) write_png("hybrid_test_wrong_shadows.png", wrong);
  for (std::size_t l = 0; l < scene.lights.size(); ++l)
    std::printf("light %zu: %zu wrong shadow-map pixels, %zu after refinement\n", l,
                wrong_raw_light[l], wrong_refined_light[l]);
  EXPECT_GT(wrong_raw, 0u);
  EXPECT_LE(wrong_refined * 10, wrong_raw);  // >= 90% of the shadow map's errors removed
}

TEST_F(HybridTest, InterleavedEqualsSequential) {
  const Scene scene = small_scene();
  HybridOptions o = small_options();
  o.width = 96;
  o.height = 72;
  std::vector<Camera> cameras(3, *scene.camera);
  cameras[1].eye = cameras[1].eye + Vec3{0.7f, 0, 0};
  cameras[2].eye = cameras[2].eye + Vec3{-0.5f, 0.4f, 0};
  std::vector<Image> images[2];
  for (int mode = 0; mode < 2; ++mode) {
    o.interleaved = mode == 1;
    HybridRenderer renderer(scene, o, *scene.camera);
    renderer.render(cameras, [&](HybridFrame&& f) { images[mode].push_back(std::move(f.image)); });
  }
  ASSERT_EQ(images[0].size(), 3u);
  ASSERT_EQ(images[1].size(), 3u);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(images[0][k].pixels, images[1][k].pixels) << "frame " << k;
  EXPECT_NE(images[0][0].pixels, images[0][1].pixels);
}

TEST_F(HybridTest, ShadowMapsAnswerSecondaryShadowsWithoutChangingTheImage) {
  const Scene scene = small_scene();
  HybridOptions o = small_options();
  o.map_secondary_shadows = false;
  HybridRenderer traced(scene, o, *scene.camera);
  const HybridFrame all_rays = traced.render_one(*scene.camera);
  o.map_secondary_shadows = true;
  HybridRenderer mapped(scene, o, *scene.camera);
  const HybridFrame with_maps = mapped.render_one(*scene.camera);
  std::printf("secondary shadows: %llu answered by maps, cpu rays %llu -> %llu\n",
              static_cast<unsigned long long>(with_maps.map_answers),
              static_cast<unsigned long long>(all_rays.cpu_rays),
              static_cast<unsigned long long>(with_maps.cpu_rays));
  EXPECT_EQ(all_rays.map_answers, 0u);
  EXPECT_GT(with_maps.map_answers, 0u);
  // Each answer saves at least one ray (more where a transparent caster would be crossed).
  EXPECT_LE(with_maps.cpu_rays + with_maps.map_answers, all_rays.cpu_rays);
  EXPECT_GE(psnr_db(with_maps.image, all_rays.image), 45.0);
}

// Animation: geometry replaced between submits; frames in flight keep their own triangles, so
// interleaved, sequential and a fresh renderer of each frame's triangles agree.
TEST_F(HybridTest, NewTrianglesBetweenFramesKeepFramesInFlightIntact) {
  const Scene scene = small_scene();
  HybridOptions o = small_options();
  o.width = 96;
  o.height = 72;
  const std::vector<Triangle> base = flatten(scene).triangles;
  const auto moved = [&](int k) {
    std::vector<Triangle> t = base;
    for (Triangle& tri : t)
      for (Vec3* v : {&tri.v0, &tri.v1, &tri.v2})
        if (v->y > 0.01f) *v = *v + Vec3{0.15f * k, 0.05f * k, 0};  // all but the floor move
    return t;
  };
  std::vector<Image> images[2];
  for (int mode = 0; mode < 2; ++mode) {
    o.interleaved = mode == 1;
    HybridRenderer renderer(scene, o, *scene.camera);
    for (int k = 0; k < 3; ++k) {
      if (k > 0) renderer.set_triangles(moved(k));
      if (auto f = renderer.submit(*scene.camera)) images[mode].push_back(std::move(f->image));
    }
    if (auto f = renderer.finish()) images[mode].push_back(std::move(f->image));
  }
  ASSERT_EQ(images[0].size(), 3u);
  ASSERT_EQ(images[1].size(), 3u);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(images[0][k].pixels, images[1][k].pixels) << "frame " << k;
  // Frame 2 equals a renderer that had frame 2's triangles from the start (same flat normals).
  HybridRenderer fresh(scene, o, *scene.camera);
  fresh.set_triangles(moved(2));
  EXPECT_EQ(fresh.render_one(*scene.camera).image.pixels, images[1][2].pixels);
  EXPECT_NE(images[1][0].pixels, images[1][2].pixels);
  EXPECT_THROW(fresh.set_triangles(std::vector<Triangle>(3)), Error);
}

TEST_F(HybridTest, BadOptionsAreErrors) {
  const Scene scene = small_scene();
  HybridOptions o = small_options();
  o.blur_kernel = 4;
  EXPECT_THROW(HybridRenderer(scene, o, Camera{}), Error);
}

}  // namespace
}  // namespace splitray

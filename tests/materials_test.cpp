// The files' own materials and textures (OBJ/MTL, glTF 2 metallic-roughness, JSON overrides),
// texture sampling, lights fitted to the view and the warning when lights reach nothing the
// camera sees, BART scenes with their camera, lights and materials, and the image formats
// (PNG, OpenEXR read back by OpenEXR's reader, PFM read back by numpy).
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>

#include "splitray/core/errors.hpp"
#include "splitray/io/aff.hpp"
#include "splitray/io/frames.hpp"
#include "splitray/io/load_scene.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/io/npy.hpp"
#include "splitray/io/texture_io.hpp"
#include "splitray/render/default_scene.hpp"
#include "splitray/render/view_lights.hpp"
#include "splitray/render/whitted.hpp"
#include "splitray/render_gl/gl_context.hpp"
#include "splitray/render_gl/hybrid.hpp"
#include "test_data.hpp"

namespace splitray {
namespace {

namespace fs = std::filesystem;

// The thresholds of the README: a render matches its reference at >= 35 dB (8-bit sRGB), and a
// picture that shows something has a luminance variance above 1e-3 (sRGB units in [0, 1]).
constexpr double kMatchDb = 35;
constexpr double kMinVariance = 1e-3;

double psnr(const Image& a, const Image& b) {
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  const auto x = a.to_srgb8(), y = b.to_srgb8();
  double sum = 0;
  for (std::size_t i = 0; i < x.size() && i < y.size(); ++i)
    sum += (static_cast<double>(x[i]) - y[i]) * (static_cast<double>(x[i]) - y[i]);
  return sum == 0 ? INFINITY : 10 * std::log10(255.0 * 255.0 * x.size() / sum);
}

double luminance_variance(const Image& image) {
  const auto bytes = image.to_srgb8();
  double sum = 0, sum2 = 0;
  const std::size_t n = bytes.size() / 3;
  for (std::size_t i = 0; i < n; ++i) {
    const double l =
        (0.2126 * bytes[3 * i] + 0.7152 * bytes[3 * i + 1] + 0.0722 * bytes[3 * i + 2]) / 255.0;
    sum += l;
    sum2 += l * l;
  }
  return sum2 / n - (sum / n) * (sum / n);
}

double mean_luminance(const Image& image) {
  double sum = 0;
  for (const Vec3& p : image.pixels) sum += 0.2126 * p.x + 0.7152 * p.y + 0.0722 * p.z;
  return sum / static_cast<double>(image.pixels.size());
}

// A reference picture of tests/references as an Image (its sRGB decoded to linear).
Image reference(const std::string& name) {
  const auto texture = load_texture((test::source_dir() / "tests/references" / name).string());
  Image image(texture->width, texture->height);
  image.pixels = texture->texels;
  return image;
}

Image render(const Scene& scene, int width, int height, const std::string& accel = "kd",
             std::optional<Camera> camera = std::nullopt) {
  RenderOptions o;
  o.width = width;
  o.height = height;
  o.accel = accel;
  return render_whitted(scene, camera ? *camera : *scene.camera, o).image;
}

void write(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

// ------------------------------------------------------------------------- texture sampling

TEST(Texture, BilinearBetweenTexelCentresAndWrapModes) {
  Texture t;
  t.width = 2;
  t.height = 2;
  t.texels = {Vec3{0}, Vec3{1}, Vec3{2}, Vec3{3}};  // top row 0 1, bottom row 2 3
  EXPECT_EQ(t.sample({0.25f, 0.75f}).x, 0);         // the top-left texel's centre
  EXPECT_EQ(t.sample({0.75f, 0.25f}).x, 3);
  EXPECT_FLOAT_EQ(t.sample({0.5f, 0.5f}).x, 1.5f);  // between all four
  EXPECT_FLOAT_EQ(t.sample({0.5f, 0.75f}).x, 0.5f);
  // repeat: one period to the right is the same; between the last and first texel it blends.
  EXPECT_EQ(t.sample({1.25f, 0.75f}), t.sample({0.25f, 0.75f}));
  EXPECT_FLOAT_EQ(t.sample({0.0f, 0.75f}).x, 0.5f);
  t.wrap_u = WrapMode::clamp;
  EXPECT_EQ(t.sample({-3.0f, 0.75f}).x, 0);
  EXPECT_EQ(t.sample({0.0f, 0.75f}).x, 0);
  EXPECT_EQ(t.sample({7.0f, 0.75f}).x, 1);
  t.wrap_u = WrapMode::mirror;
  EXPECT_EQ(t.sample({1.25f, 0.75f}).x, t.sample({0.75f, 0.75f}).x);
  EXPECT_EQ(t.sample({-0.25f, 0.75f}).x, t.sample({0.25f, 0.75f}).x);
}

// --------------------------------------------------------------------- materials from files

TEST(Materials, SpiderObjMtlWithPngTextures) {
  const Scene scene = load_scene(test::vendored_file("spider/spider.obj"));
  EXPECT_TRUE(scene.warnings.empty()) << scene.warnings.front();
  const Mesh& mesh = scene.meshes.at(0);
  ASSERT_EQ(mesh.materials.size(), 4u);  // of the MTL's five, the four the faces use
  EXPECT_EQ(mesh.face_materials.size(), mesh.faces.size());
  EXPECT_EQ(mesh.uvs.size(), mesh.positions.size());
  for (const Material& m : mesh.materials) {
    ASSERT_TRUE(m.diffuse_texture) << m.name;  // map_Kd .\NAME.png (a Windows path)
    EXPECT_GT(m.diffuse_texture->width, 0);
  }
  const auto skin = std::find_if(mesh.materials.begin(), mesh.materials.end(),
                                 [](const Material& m) { return m.name == "Skin"; });
  ASSERT_NE(skin, mesh.materials.end());
  EXPECT_NEAR(skin->diffuse.x, 0.827451f, 1e-6f);
  EXPECT_EQ(skin->diffuse_texture->width, 250);
}

TEST(Materials, MtlKeysAndIlluminationModels) {
  const fs::path dir = test::temp_dir("materials_mtl");
  write(dir / "m.mtl", R"(newmtl matte
Kd 0.5 0.25 0.125
Ks 0.5 0.5 0.5
Ns 40
illum 1
newmtl mirror
Kd 0.1 0.1 0.1
Ks 0.6 0.6 0.6
illum 3
newmtl glass
Kd 0 0 0
d 0.2
Ni 1.33
illum 7
newmtl veil
Kd 1 1 1
Tr 0.25
illum 2
map_Kd -clamp on missing.png
)");
  std::string obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n";
  for (const char* m : {"matte", "mirror", "glass", "veil"})
    obj += std::string("usemtl ") + m + "\nf 1/1 2/2 3/3\n";
  write(dir / "m.obj", obj);
  const Scene scene = load_scene((dir / "m.obj").string());
  const auto& ms = scene.meshes.at(0).materials;
  ASSERT_EQ(ms.size(), 4u);
  EXPECT_EQ(ms[0].diffuse, (Vec3{0.5f, 0.25f, 0.125f}));
  EXPECT_EQ(ms[0].specular, Vec3{0});   // illum 1: no highlight
  EXPECT_EQ(ms[1].reflectivity, 0.6f);  // illum 3: mirror of Ks's strength
  EXPECT_EQ(ms[1].specular, Vec3{0.6f});
  EXPECT_NEAR(ms[2].transparency, 0.8f, 1e-6f);  // d 0.2, refracting glass with Fresnel
  EXPECT_FLOAT_EQ(ms[2].ior, 1.33f);
  EXPECT_TRUE(ms[2].fresnel);
  EXPECT_NEAR(ms[3].transparency, 0.25f, 1e-6f);  // Tr 0.25 = d 0.75, see-through (illum 2)
  EXPECT_EQ(ms[3].ior, 1.0f);
  EXPECT_FALSE(ms[3].diffuse_texture);
  ASSERT_EQ(scene.warnings.size(), 1u);  // the missing texture: a warning, not an error
  EXPECT_NE(scene.warnings[0].find("missing.png"), std::string::npos) << scene.warnings[0];
  const std::vector<std::uint32_t> per_face{0, 1, 2, 3};
  EXPECT_EQ(scene.meshes[0].face_materials, per_face);
  // -clamp on: the texture's wrap mode (checked on an existing texture).
  write(dir / "m.mtl", "newmtl veil\nmap_Kd -clamp on t.png\n");
  fs::copy_file(test::vendored_file("spider/engineflare1.png"), dir / "t.png");
  write(dir / "c.obj", "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl veil\nf 1 2 3\n");
  const Scene clamped = load_scene((dir / "c.obj").string());
  ASSERT_TRUE(clamped.meshes[0].materials.at(0).diffuse_texture);
  EXPECT_EQ(clamped.meshes[0].materials[0].diffuse_texture->wrap_u, WrapMode::clamp);
}

TEST(Materials, GltfMetallicRoughnessInPhong) {
  nlohmann::json gltf =
      nlohmann::json::parse(test::read_text(test::source_dir() / "tests/fixtures/quads.gltf"));
  gltf["materials"] = {{{"name", "brass"},
                        {"pbrMetallicRoughness",
                         {{"baseColorFactor", {0.8, 0.4, 0.2, 1.0}},
                          {"metallicFactor", 0.5},
                          {"roughnessFactor", 0.25}}}}};
  for (auto& mesh : gltf["meshes"])
    for (auto& primitive : mesh["primitives"]) primitive["material"] = 0;
  const fs::path dir = test::temp_dir("materials_gltf");
  write(dir / "brass.gltf", gltf.dump());
  const Scene scene = load_scene((dir / "brass.gltf").string());
  const Material& m = scene.meshes.at(0).materials.at(0);
  EXPECT_NEAR(m.diffuse.x, 0.8f * 0.5f, 1e-6f);  // base x (1 - metallic)
  EXPECT_NEAR(m.diffuse.z, 0.2f * 0.5f, 1e-6f);
  EXPECT_NEAR(m.specular.x, 0.04f * 0.5f + 0.8f * 0.5f, 1e-6f);  // F0 towards the base colour
  EXPECT_NEAR(m.shininess, 2 / (0.0625f * 0.0625f) - 2, 1e-2f);  // alpha = roughness^2
  EXPECT_NEAR(m.reflectivity, 0.5f * 0.75f * 0.75f, 1e-6f);
}

TEST(Materials, ColladaDiffuseTextureThroughAssimpsKeys) {
  SPLITRAY_REQUIRE_SHARED(path, "skinned_khronos_gltf1/CesiumMan/collada/CesiumMan.dae");
  const Scene scene = load_scene(path);
  EXPECT_TRUE(scene.warnings.empty()) << scene.warnings.front();
  const Mesh& mesh = scene.meshes.at(0);
  ASSERT_FALSE(mesh.materials.empty());
  ASSERT_TRUE(mesh.materials[0].diffuse_texture);  // CesiumMan.jpg beside the file
  EXPECT_EQ(mesh.uvs.size(), mesh.positions.size());
  EXPECT_GT(luminance_variance(render(scene, 96, 96)), kMinVariance);
}

TEST(Materials, JsonInstanceOverridesTheFilesMaterials) {
  const fs::path dir = test::temp_dir("materials_json");
  const std::string spider = test::vendored_file("spider/spider.obj");
  write(dir / "scene.json",
        R"({"materials": [{"name": "red", "diffuse": [0.9, 0.1, 0.1]}],
            "instances": [{"mesh": ")" +
            spider + R"(", "material": "red"},
                          {"mesh": ")" +
            spider + R"(", "transform": {"translate": [100, 0, 0]}}]})");
  const Scene scene = load_scene((dir / "scene.json").string());
  const FlatScene flat = flatten(scene);
  const std::size_t half = flat.triangles.size() / 2;
  for (std::size_t t = 0; t < flat.triangles.size(); ++t) {
    const Material& m = flat.materials[flat.material[t]];
    if (t < half)
      ASSERT_EQ(m.name, "red") << t;
    else
      ASSERT_TRUE(m.diffuse_texture) << t;  // the second instance keeps the file's own
  }
}

// ------------------------------------------------------------------ rendering with textures

TEST(TexturedRender, SpiderMatchesTheReferenceAndShowsItsTextures) {
  const Scene scene = load_scene(test::vendored_file("spider/spider.obj"));
  const Image image = render(scene, 200, 150);
  const Image expected = reference("spider.png");
  EXPECT_GE(psnr(image, expected), kMatchDb);
  EXPECT_GT(luminance_variance(image), kMinVariance);
  Scene untextured = scene;
  for (Material& m : untextured.meshes[0].materials) m.diffuse_texture.reset();
  EXPECT_LT(psnr(render(untextured, 200, 150), expected), 30) << "the textures do not show";
}

TEST(TexturedRender, HybridRendererSamplesTexturesAsWhittedDoes) {
  const Scene scene = load_scene(test::vendored_file("spider/spider.obj"));
  HybridOptions o;
  o.width = 200;
  o.height = 150;
  RenderResult hybrid;
  try {
    hybrid = render_hybrid(scene, *scene.camera, o);
  } catch (const Error& e) {
    GTEST_SKIP() << "no usable headless OpenGL: " << e.what();
  }
  EXPECT_GE(psnr(hybrid.image, reference("spider.png")), kMatchDb);
  EXPECT_GT(luminance_variance(hybrid.image), kMinVariance);
}

// ------------------------------------------------------------------ lights fitted to the view

TEST(ViewLights, CameraInsideTheSibenikNaveIsLit) {
  SPLITRAY_REQUIRE_SHARED(path, "static_sibenik/sibenik.obj");
  Scene scene = load_scene(path);
  ASSERT_TRUE(scene.lights_fit_view);
  Camera inside;  // the README's camera down the nave
  inside.eye = {-17, -13.6f, 0};
  inside.target = {19, -9, 0};
  inside.vfov_degrees = 60;
  RenderOptions o;
  o.width = 96;
  o.height = 72;
  o.accel = "bvh";
  const RenderResult lit = render_whitted(scene, inside, o);
  ASSERT_EQ(lit.lights.size(), 2u);  // the head light and a key light inside the nave
  EXPECT_EQ(lit.lights[0].position, inside.eye);
  EXPECT_TRUE(scene.bounds().contains(lit.lights[1].position));
  EXPECT_GT(lit.coverage.lit, lit.coverage.probes / 2);
  scene.lights_fit_view = false;  // no lights at all: only the ambient term
  const RenderResult dark = render_whitted(scene, inside, o);
  EXPECT_GT(mean_luminance(lit.image), 4 * mean_luminance(dark.image));
  EXPECT_GT(mean_luminance(lit.image), 0.08);
  EXPECT_GT(luminance_variance(lit.image), kMinVariance);
  EXPECT_FALSE(coverage_warning(dark.coverage, dark.lights.size()).empty());
}

TEST(ViewLights, WarnsWhenNoLightReachesWhatTheCameraSees) {
  Scene scene = load_scene(test::vendored_file("horse/horse.obj.gz"));
  scene.lights_fit_view = false;
  Light behind;  // shines from the camera's back towards it: lights only what it cannot see
  behind.kind = Light::Kind::directional;
  behind.direction = normalize(scene.camera->eye - scene.camera->target);
  scene.lights = {behind};
  RenderOptions o;
  o.width = 64;
  o.height = 48;
  const RenderResult r = render_whitted(scene, *scene.camera, o);
  EXPECT_GT(r.coverage.probes, 0);
  EXPECT_EQ(r.coverage.lit, 0);
  EXPECT_NE(coverage_warning(r.coverage, 1).find("no light"), std::string::npos);
  scene.lights[0].direction = -behind.direction;  // now from the camera's side: no warning
  EXPECT_TRUE(coverage_warning(render_whitted(scene, *scene.camera, o).coverage, 1).empty());
}

// ------------------------------------------------------------------------------ BART scenes

TEST(Aff, MuseumRendersWithItsOwnCameraLightsAndMaterials) {
  SPLITRAY_REQUIRE_SHARED(path, "anim_bart_museum/aff/museum5.aff");
  const Scene scene = load_scene(path);
  ASSERT_TRUE(scene.camera);
  // The camera path at the animation's start (a -1): keys at -1 place the eye at (0, 1.8, -9)
  // looking down +z.
  EXPECT_NEAR(scene.camera->eye.x, 0, 1e-4f);
  EXPECT_NEAR(scene.camera->eye.y, 1.8f, 1e-4f);
  EXPECT_NEAR(scene.camera->eye.z, -9, 1e-4f);
  EXPECT_GT(normalize(scene.camera->target - scene.camera->eye).z, 0.99f);
  ASSERT_EQ(scene.lights.size(), 2u);
  EXPECT_FALSE(scene.lights[0].falloff);
  EXPECT_EQ(scene.lights[0].color, Vec3{0.5f});
  EXPECT_EQ(scene.background, (Vec3{0.5f, 0.5f, 1.0f}));
  EXPECT_GT(scene.meshes[0].materials.size(), 10u);
  const Image image = render(scene, 160, 120);
  EXPECT_GE(psnr(image, reference("museum.png")), kMatchDb);
  EXPECT_GT(luminance_variance(image), kMinVariance);
  EXPECT_LT(psnr(image, render(scene, 160, 120, "kd", Camera::frame(scene.bounds()))), 20)
      << "the file's camera must differ from the framed view";
}

TEST(Aff, CameraPathFollowsTheKeyFrames) {
  SPLITRAY_REQUIRE_SHARED(path, "anim_bart_museum/aff/museum5.aff");
  const FrameSequence frames({path});
  ASSERT_GT(frames.size(), 2u);
  const Camera first = *frames.camera(0), middle = *frames.camera(frames.size() / 2);
  EXPECT_GT(length(first.eye - middle.eye), 1.0f);  // the camera walks into the museum
  const AffScene aff = AffScene::load(path);
  EXPECT_EQ(aff.camera_at(aff.animation().start)->eye, first.eye);
  ASSERT_TRUE(frames.scene());
  EXPECT_EQ(frames.scene()->meshes[0].face_materials.size(), aff.triangle_count());
}

// ------------------------------------------------------------------------------ image files

Image hdr_image() {
  Image image(7, 5);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      image.at(x, y) = {0.01f * x, 3.5f * y + 0.25f, 100.0f / (1 + x + y)};  // beyond 1: HDR
  return image;
}

Image read_exr(const std::string& path) {
  Imf::InputFile file(path.c_str());
  const Imath::Box2i window = file.header().dataWindow();
  Image image(window.max.x - window.min.x + 1, window.max.y - window.min.y + 1);
  Imf::FrameBuffer buffer;
  char* base = reinterpret_cast<char*>(image.pixels.data());
  for (int c = 0; c < 3; ++c)
    buffer.insert(std::string(1, "RGB"[c]),
                  Imf::Slice(Imf::FLOAT, base + c * sizeof(float), sizeof(Vec3),
                             sizeof(Vec3) * static_cast<std::size_t>(image.width)));
  file.setFrameBuffer(buffer);
  file.readPixels(window.min.y, window.max.y);
  return image;
}

TEST(ImageFiles, OpenExrRoundTripsThroughOpenExrsReader) {
  const fs::path dir = test::temp_dir("images_exr");
  const Image image = hdr_image();
  write_image((dir / "float.exr").string(), image, {.exr_float = true});
  write_image((dir / "half.EXR").string(), image);
  const Image full = read_exr((dir / "float.exr").string()),
              half = read_exr((dir / "half.EXR").string());
  ASSERT_EQ(full.width, image.width);
  ASSERT_EQ(half.height, image.height);
  EXPECT_EQ(full.pixels, image.pixels);  // float: exact
  for (std::size_t i = 0; i < image.pixels.size(); ++i)
    for (int c = 0; c < 3; ++c)  // half: 11 significant bits
      EXPECT_NEAR(half.pixels[i][c], image.pixels[i][c], 1e-3f * image.pixels[i][c] + 1e-4f);
}

TEST(ImageFiles, PfmRoundTripsThroughNumpy) {
  if (std::system("/usr/bin/python3 -c 'import numpy' > /dev/null 2>&1") != 0)
    GTEST_SKIP() << "/usr/bin/python3 with numpy is absent";
  const fs::path dir = test::temp_dir("images_pfm");
  const Image image = hdr_image();
  write_image((dir / "image.pfm").string(), image);
  std::vector<float> values;
  for (const Vec3& p : image.pixels) values.insert(values.end(), {p.x, p.y, p.z});
  write_npz((dir / "expected.npz").string(),
            {{"rgb", npy_array({static_cast<std::size_t>(image.height),
                                static_cast<std::size_t>(image.width), 3},
                               values)}});
  // numpy reads the PFM as the format says (header, scale < 0: little-endian, bottom row
  // first) and compares it with the float image, top row first.
  const std::string script =
      "import numpy as np, sys\n"
      "d = sys.argv[1]\n"
      "raw = open(d + '/image.pfm', 'rb').read()\n"
      "parts = raw.split(b'\\n', 3)\n"
      "assert parts[0] == b'PF', parts[0]\n"
      "w, h = map(int, parts[1].split())\n"
      "assert float(parts[2]) < 0\n"
      "img = np.frombuffer(parts[3], dtype='<f4').reshape(h, w, 3)[::-1]\n"
      "ref = np.load(d + '/expected.npz')['rgb']\n"
      "assert img.shape == ref.shape, (img.shape, ref.shape)\n"
      "assert np.array_equal(img, ref), np.abs(img - ref).max()\n";
  write(dir / "check.py", script);
  EXPECT_EQ(std::system(("/usr/bin/python3 " + test::quote((dir / "check.py").string()) + " " +
                         test::quote(dir.string()))
                            .c_str()),
            0);
}

TEST(ImageFiles, UnknownExtensionIsAnErrorAndWritesNothing) {
  const fs::path dir = test::temp_dir("images_unknown");
  for (const char* name : {"out.jpg", "out", "out.png.tmp"}) {
    const std::string path = (dir / name).string();
    try {
      write_image(path, hdr_image());
      ADD_FAILURE() << name << " was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(".exr"), std::string::npos) << e.what();
    }
  }
  EXPECT_TRUE(fs::is_empty(dir));
  EXPECT_EQ(check_image_path((dir / "x.PNG").string()), ImageFormat::png);
  EXPECT_EQ(check_image_path((dir / "x.pfm").string()), ImageFormat::pfm);
  EXPECT_THROW(check_image_path((dir / "nowhere" / "x.png").string()), Error);
}

}  // namespace
}  // namespace splitray

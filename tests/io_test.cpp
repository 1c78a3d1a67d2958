// Mesh and scene loading: every format on real data and on small fixtures, gzip, the JSON
// scene format, and one test per kind of malformed or hostile input.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "splitray/core/errors.hpp"
#include "splitray/io/frames.hpp"
#include "splitray/io/load_scene.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/io/read_file.hpp"
#include "splitray/io/triangulate.hpp"
#include "test_data.hpp"

// assimp 5.2 leaks on some of its error paths (e.g. ASCII STL with a bad number); those are
// not ours to fix, and must not fail the sanitizer build of this test.
extern "C" const char* __lsan_default_suppressions() { return "leak:libassimp.so\n"; }

namespace splitray {
namespace {

namespace fs = std::filesystem;

std::string fixture(const std::string& name) {
  return (test::source_dir() / "tests" / "fixtures" / name).string();
}

using splitray::test::read_text;
std::string write(const fs::path& dir, const std::string& name, const std::string& bytes) {
  const fs::path path = dir / name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path.string();
}

std::string gzip(const std::string& data) {
  z_stream zs{};
  EXPECT_EQ(deflateInit2(&zs, Z_BEST_SPEED, Z_DEFLATED, 16 + MAX_WBITS, 8, Z_DEFAULT_STRATEGY),
            Z_OK);
  std::string out(deflateBound(&zs, data.size()), '\0');
  zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  zs.avail_in = static_cast<uInt>(data.size());
  zs.next_out = reinterpret_cast<Bytef*>(out.data());
  zs.avail_out = static_cast<uInt>(out.size());
  EXPECT_EQ(deflate(&zs, Z_FINISH), Z_STREAM_END);
  out.resize(zs.total_out);
  deflateEnd(&zs);
  return out;
}

// The call must throw an Error whose message starts with `path` and contains `word`.
void expect_error(const std::function<void()>& call, const std::string& path,
                  const std::string& word) {
  try {
    call();
    ADD_FAILURE() << "no error for " << path << " (expected one mentioning '" << word << "')";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_TRUE(message.starts_with(path + ":"))
        << "message does not start with the path: " << message;
    EXPECT_NE(message.find(word), std::string::npos)
        << "'" << word << "' missing from: " << message;
  }
}

void expect_mesh_error(const std::string& path, const std::string& word) {
  expect_error([&] { load_mesh(path); }, path, word);
}

Aabb bounds(const std::vector<Triangle>& triangles) {
  Aabb box;
  for (const Triangle& t : triangles) {
    box.extend(t.v0);
    box.extend(t.v1);
    box.extend(t.v2);
  }
  return box;
}

void expect_box(const Aabb& box, Vec3 lo, Vec3 hi, float tolerance = 1e-5f) {
  for (int a = 0; a < 3; ++a) {
    EXPECT_NEAR(box.lo[a], lo[a], tolerance) << "axis " << a;
    EXPECT_NEAR(box.hi[a], hi[a], tolerance) << "axis " << a;
  }
}

double total_area(const Mesh& mesh) {
  double area = 0;
  for (std::size_t f = 0; f < mesh.triangle_count(); ++f)
    area += 0.5 * length(mesh.triangle(f).geometric_normal());
  return area;
}

// A fresh folder named after the running test.
class Io : public ::testing::Test {
 protected:
  fs::path dir() {
    if (dir_.empty())
      dir_ = test::temp_dir(std::string("io_") +
                            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    return dir_;
  }
  std::string file(const std::string& name, const std::string& bytes) {
    return write(dir(), name, bytes);
  }

 private:
  fs::path dir_;
};

// ---------------------------------------------------------------- real data

TEST(IoRealData, CornellBoxQuadsBecome36Triangles) {
  SPLITRAY_REQUIRE_SHARED(path, "static_cornell_box/cornell_box.obj");
  const Mesh mesh = load_mesh(path);
  EXPECT_EQ(mesh.triangle_count(), 36u);
  expect_box(mesh.bounds(), {0, 0, 0}, {556, 548.8f, 559.2f}, 1e-3f);
}

TEST(IoRealData, Dragon100k) {
  SPLITRAY_REQUIRE_SHARED(path, "static_dragon_100k/dragon.obj");
  const Mesh mesh = load_mesh(path);  // its mtllib names a missing file: harmless
  EXPECT_EQ(mesh.triangle_count(), 100000u);
  EXPECT_EQ(mesh.positions.size(), 50000u);
  expect_box(mesh.bounds(), {-7.0467f, 0, -3.1513f}, {7.0467f, 9.9399f, 3.1513f}, 1e-3f);
}

TEST(IoRealData, SibenikKeepsItsDegenerateTriangles) {
  SPLITRAY_REQUIRE_SHARED(path, "static_sibenik/sibenik.obj");
  const Mesh mesh = load_mesh(path);
  EXPECT_EQ(mesh.triangle_count(), 75284u);
  std::size_t zero_area = 0;
  for (std::size_t f = 0; f < mesh.triangle_count(); ++f)
    zero_area += mesh.triangle(f).geometric_normal() == Vec3{};
  EXPECT_GE(zero_area, 9u);  // SOURCE.md counts 10 in its own arithmetic; 9 are exactly 0 in float
}

TEST(IoRealData, FaerieMd2IsTheFirstFrame) {
  SPLITRAY_REQUIRE_SHARED(path, "anim_md2_faerie/faerie.md2");
  SPLITRAY_REQUIRE_SHARED(frame0, "anim_md2_faerie/frames/faerie_000.obj");
  const Mesh mesh = load_mesh(path);
  EXPECT_EQ(mesh.triangle_count(), 654u);
  EXPECT_EQ(mesh.normals.size(), mesh.positions.size());
  // assimp turns MD2's Z-up into Y-up: (x, y, z) -> (x, z, -y).
  const Aabb baked = load_mesh(frame0).bounds();
  expect_box(mesh.bounds(), {baked.lo.x, baked.lo.z, -baked.hi.y},
             {baked.hi.x, baked.hi.z, -baked.lo.y}, 1e-3f);
}

TEST(IoRealData, CcdFramePairsBinaryPly) {
  const std::pair<const char*, std::size_t> scenes[] = {
      {"armadillo-rollers/frames/326.ply", 24242},
      {"armadillo-rollers/frames/327.ply", 24242},
      {"cloth-funnel/frames/227.ply", 18484},
      {"cloth-funnel/frames/228.ply", 18484},
      {"n-body-simulation/frames/balls16_18.ply", 146480},  // big-endian with colours
      {"n-body-simulation/frames/balls16_19.ply", 146480},
      {"rod-twist/frames/3036.ply", 79864},
      {"rod-twist/frames/3037.ply", 79864}};
  for (const auto& [name, triangles] : scenes) {
    SPLITRAY_REQUIRE_SHARED(path, std::string("anim_ccd_frame_pairs/") + name);
    EXPECT_EQ(load_mesh(path).triangle_count(), triangles) << name;
  }
}

TEST(IoRealData, SkinnedModelsGltf1AndColladaAgree) {
  const std::tuple<const char*, const char*, std::size_t> models[] = {
      {"CesiumMan/glTF/CesiumMan.gltf", "CesiumMan/collada/CesiumMan.dae", 4672},
      {"RiggedFigure/glTF/RiggedFigure.gltf", "RiggedFigure/collada/RiggedFigure.dae", 256},
      {"RiggedSimple/glTF/RiggedSimple.gltf", "RiggedSimple/collada/riggedSimple.dae", 188}};
  for (const auto& [gltf_name, dae_name, triangles] : models) {
    SPLITRAY_REQUIRE_SHARED(gltf, std::string("skinned_khronos_gltf1/") + gltf_name);
    SPLITRAY_REQUIRE_SHARED(dae, std::string("skinned_khronos_gltf1/") + dae_name);
    const Mesh a = load_mesh(gltf), b = load_mesh(dae);  // glTF 1.0 and COLLADA 1.4
    EXPECT_EQ(a.triangle_count(), triangles) << gltf_name;
    EXPECT_EQ(b.triangle_count(), triangles) << dae_name;
    // The COLLADA files are Z-up, the glTF ones Y-up through a root node: equal bounds mean
    // that node transforms were applied in both.
    const Aabb box = a.bounds();
    expect_box(b.bounds(), box.lo, box.hi, 1e-4f);
  }
}

TEST(IoRealData, GzippedCatKeepsItsNormals) {
  SPLITRAY_REQUIRE_SHARED(path, "static_sumner_cat_lion_poses/cat-poses/cat-reference.obj.gz");
  const Mesh mesh = load_mesh(path);
  EXPECT_EQ(mesh.triangle_count(), 14410u);
  EXPECT_EQ(mesh.positions.size(), 7207u);
  ASSERT_EQ(mesh.normals.size(), mesh.positions.size());
  for (const Vec3& n : mesh.normals) ASSERT_NEAR(length(n), 1.0f, 1e-4f);
}

TEST(IoRealData, VendoredMeshes) {
  EXPECT_EQ(load_mesh(test::vendored_file("horse/horse.obj.gz")).triangle_count(), 16843u);
  EXPECT_EQ(load_mesh(test::vendored_file("dragon_100k/dragon.obj.gz")).triangle_count(), 100000u);
}

// ---------------------------------------------------------------- every format, small fixtures

TEST(IoFormats, UnitCubeInEveryFormat) {
  for (const char* name : {"cube.obj", "cube_ascii.ply", "cube_binary.ply", "cube_binary_be.ply",
                           "cube_ascii.stl", "cube_binary.stl", "cube.off"}) {
    const Mesh mesh = load_mesh(fixture(name));
    EXPECT_EQ(mesh.triangle_count(), 12u) << name;  // 6 quads triangulated (STL: triangles)
    EXPECT_EQ(mesh.positions.size(), 8u) << name;
    expect_box(mesh.bounds(), {0, 0, 0}, {1, 1, 1});
    EXPECT_NEAR(total_area(mesh), 6.0, 1e-6) << name;
    EXPECT_EQ(mesh.name, fixture(name));
  }
}

TEST(IoFormats, ObjConcavePolygonAndRelativeIndices) {
  const Mesh mesh = load_mesh(fixture("polygons.obj"));
  EXPECT_EQ(mesh.triangle_count(), 5u);      // L-shaped hexagon: 4, triangle: 1
  EXPECT_NEAR(total_area(mesh), 3.5, 1e-6);  // concave polygon triangulated inside its outline
}

TEST(IoFormats, GltfNodeTransformsAndNormals) {
  for (const char* name : {"quads.gltf", "quads_external.gltf", "quads.glb"}) {
    const Mesh mesh = load_mesh(fixture(name));
    EXPECT_EQ(mesh.triangle_count(), 4u) << name;  // one quad instanced by two nodes
    expect_box(mesh.bounds(), {10, 0, 0}, {11, 1, 6});
    ASSERT_EQ(mesh.normals.size(), mesh.positions.size()) << name;
    int up = 0, turned = 0;  // (0,0,1) as stored, and rotated 90 degrees about x
    for (const Vec3& n : mesh.normals) {
      up += length(n - Vec3{0, 0, 1}) < 1e-5f;
      turned += length(n - Vec3{0, -1, 0}) < 1e-5f;
    }
    EXPECT_EQ(up, 4) << name;
    EXPECT_EQ(turned, 4) << name;
  }
}

TEST(IoFormats, ColladaZUpBecomesYUp) {
  const Mesh mesh = load_mesh(fixture("quad.dae"));
  EXPECT_EQ(mesh.triangle_count(), 2u);  // one polylist quad
  expect_box(mesh.bounds(), {0, 2, -1}, {1, 2, 0});
}

TEST(IoFormats, Md2) {
  const Mesh mesh = load_mesh(fixture("quad.md2"));
  EXPECT_EQ(mesh.triangle_count(), 2u);
  expect_box(mesh.bounds(), {0, 0, -1}, {1, 0, 0});
}

TEST_F(Io, NonSimplePolygonKeepsAllItsTriangles) {  // assimp 5.2 would leave some out
  const std::string path =
      file("bowtie.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3 4 1 2 3 4\n");
  EXPECT_EQ(load_mesh(path).triangle_count(), 6u);
}

TEST_F(Io, DegenerateTrianglesAreKept) {
  const std::string path =
      file("degenerate.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 4\nf 1 2 3\nf 1 1 4\n");
  const Mesh mesh = load_mesh(path);
  EXPECT_EQ(mesh.triangle_count(), 3u);
}

TEST_F(Io, ObjNormalsAreKept) {
  const std::string path =
      file("normals.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 2\nf 1//1 2//1 3//1\n");
  const Mesh mesh = load_mesh(path);
  ASSERT_EQ(mesh.normals.size(), 3u);
  for (const Vec3& n : mesh.normals) EXPECT_EQ(n, (Vec3{0, 0, 1}));
}

TEST_F(Io, UpperCaseExtension) {
  EXPECT_EQ(load_mesh(file("CUBE.OBJ", read_text(fixture("cube.obj")))).triangle_count(), 12u);
}

TEST_F(Io, GzipReadsLikeThePlainFile) {
  // The external glTF buffer is found beside the .gz, as it would be beside the plain file.
  fs::copy_file(fixture("quads_external.bin"), dir() / "quads_external.bin");
  for (const char* name : {"cube.obj", "cube_binary.ply", "cube_ascii.stl", "cube.off", "quads.glb",
                           "quads_external.gltf", "quad.dae", "quad.md2"}) {
    const Mesh plain = load_mesh(fixture(name));
    const Mesh packed = load_mesh(file(std::string(name) + ".gz", gzip(read_text(fixture(name)))));
    EXPECT_EQ(packed.positions, plain.positions) << name;
    EXPECT_EQ(packed.faces, plain.faces) << name;
    EXPECT_EQ(packed.normals, plain.normals) << name;
  }
}

TEST_F(Io, GzipWithSeveralMembers) {
  const std::string text = read_text(fixture("cube.obj"));
  const std::size_t half = text.size() / 2;
  const std::string path =
      file("cube.obj.gz", gzip(text.substr(0, half)) + gzip(text.substr(half)));
  EXPECT_EQ(load_mesh(path).triangle_count(), 12u);
}

TEST_F(Io, LoadSceneOfAMeshFile) {
  const Scene scene = load_scene(fixture("cube.off"));
  EXPECT_EQ(scene.meshes.size(), 1u);
  EXPECT_EQ(scene.instances.size(), 1u);
  EXPECT_TRUE(scene.lights.empty());  // lit for the view when rendered
  EXPECT_TRUE(scene.lights_fit_view);
  EXPECT_TRUE(scene.camera.has_value());
}

// ---------------------------------------------------------------- polygon triangulation

// Triangulates `polygon` and checks: n - 2 triangles, all wound like the polygon, and (for a
// simple polygon) total area equal to the polygon's.
void check_triangulation(const std::vector<Vec3>& polygon, bool simple = true) {
  std::vector<std::array<std::uint32_t, 3>> triangles;
  triangulate_polygon(polygon, triangles);
  ASSERT_EQ(triangles.size(), polygon.size() - 2);
  Vec3 normal{};  // Newell
  for (std::size_t i = 0; i < polygon.size(); ++i)
    normal += cross(polygon[i], polygon[(i + 1) % polygon.size()]);
  const double polygon_area = 0.5 * length(normal);
  double area = 0;
  for (const auto& t : triangles) {
    const Triangle tri{polygon[t[0]], polygon[t[1]], polygon[t[2]]};
    if (simple) {
      EXPECT_GE(dot(tri.geometric_normal(), normal), 0) << "triangle wound against the polygon";
    }
    area += tri.area();
  }
  if (simple) {
    EXPECT_NEAR(area, polygon_area, 1e-4 * polygon_area);
  }
}

TEST(IoTriangulate, ConvexPolygonIsTheFanFromCornerZero) {
  const std::vector<Vec3> hexagon{{2, 0, 0},  {1, 1.7f, 0},   {-1, 1.7f, 0},
                                  {-2, 0, 0}, {-1, -1.7f, 0}, {1, -1.7f, 0}};
  std::vector<std::array<std::uint32_t, 3>> triangles;
  triangulate_polygon(hexagon, triangles);
  const std::vector<std::array<std::uint32_t, 3>> fan{{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 4, 5}};
  EXPECT_EQ(triangles, fan);
  check_triangulation(hexagon);
}

TEST(IoTriangulate, ConcavePolygonsInBothWindingsAndTilted) {
  std::vector<Vec3> ell{{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0}, {1, 2, 0}, {0, 2, 0}};
  check_triangulation(ell);
  check_triangulation({ell.rbegin(), ell.rend()});
  const Transform tilt = Transform::rotate({1, 2, 3}, 50);
  for (Vec3& v : ell) v = tilt.point(v);
  check_triangulation(ell);
  std::vector<Vec3> star;  // 12 corners, every other one reflex
  for (int i = 0; i < 12; ++i) {
    const float r = i % 2 ? 1.0f : 3.0f, a = static_cast<float>(i) * 3.14159265f / 6;
    star.push_back({r * std::cos(a), 0.5f, r * std::sin(a)});
  }
  check_triangulation(star);
  std::vector<Vec3> comb;  // teeth along x: a polygon with many reflex corners
  for (int i = 0; i < 20; ++i) {
    comb.push_back({float(2 * i), 0, 0});
    comb.push_back({float(2 * i), 5, 0});
    comb.push_back({float(2 * i + 1), 5, 0});
    comb.push_back({float(2 * i + 1), 1, 0});
  }
  comb.push_back({40, 0, 0});
  std::reverse(comb.begin(), comb.end());
  check_triangulation(comb);
}

TEST(IoTriangulate, CollinearAndRepeatedCorners) {
  check_triangulation({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {2, 2, 0}, {1, 2, 0}, {0, 2, 0}});
  check_triangulation({{0, 0, 0}, {1, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}});
  check_triangulation({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}},
                      false);  // flat: n - 2 degenerate triangles
  check_triangulation({{0, 0, 0}, {1, 1, 0}, {1, 0, 0}, {0, 1, 0}}, false);  // bow tie
}

// ---------------------------------------------------------------- files that are not there

TEST_F(Io, NonexistentFile) { expect_mesh_error((dir() / "nothing.obj").string(), "no such file"); }
TEST_F(Io, Directory) {
  fs::create_directory(dir() / "folder.obj");
  expect_mesh_error((dir() / "folder.obj").string(), "directory");
}
TEST_F(Io, Fifo) {  // reading it would block forever
  const std::string path = (dir() / "pipe.obj").string();
  ASSERT_EQ(mkfifo(path.c_str(), 0600), 0);
  expect_mesh_error(path, "not a regular file");
}
TEST_F(Io, EmptyFile) { expect_mesh_error(file("empty.obj", ""), "empty"); }
TEST_F(Io, NoExtension) {
  expect_mesh_error(file("cube", read_text(fixture("cube.obj"))), "extension");
}
TEST_F(Io, UnknownExtension) {
  expect_mesh_error(file("cube.xyz", read_text(fixture("cube.obj"))), "not a mesh format");
}
TEST_F(Io, GzWithoutInnerExtension) {
  expect_mesh_error(file("cube.gz", gzip(read_text(fixture("cube.obj")))), "extension");
}

// ---------------------------------------------------------------- truncated files

TEST_F(Io, BinaryPlyCutShort) {
  const std::string bytes = read_text(fixture("cube_binary.ply"));
  expect_mesh_error(file("cut.ply", bytes.substr(0, bytes.size() - 7)), "truncated");
}
TEST_F(Io, BinaryStlCutShort) {
  const std::string bytes = read_text(fixture("cube_binary.stl"));
  expect_mesh_error(file("cut.stl", bytes.substr(0, bytes.size() - 20)), "truncated");
}
TEST_F(Io, AsciiStlWithoutEndsolid) {
  const std::string text = read_text(fixture("cube_ascii.stl"));
  expect_mesh_error(file("cut.stl", text.substr(0, text.find("endsolid"))), "truncated");
}
TEST_F(Io, ObjCutInsideAFaceLine) {
  expect_mesh_error(file("cut.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2"), "truncated");
}
TEST_F(Io, ObjCutInsideAVertexLine) {
  expect_mesh_error(file("cut.obj", "v 0 0 0\nv 1 0 0\nv 0 1"), "3 coordinates");
}
TEST_F(Io, PlyHeaderWithoutEnd) {  // assimp 5.2 loops forever on this one
  expect_mesh_error(
      file("header.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"),
      "end_header");
}
TEST_F(Io, OffCutShort) {
  const std::string text = read_text(fixture("cube.off"));
  expect_mesh_error(file("cut.off", text.substr(0, text.size() - 30)), "truncated");
}
TEST_F(Io, GlbCutShort) {
  const std::string bytes = read_text(fixture("quads.glb"));
  expect_mesh_error(file("cut.glb", bytes.substr(0, bytes.size() - 40)), "assimp");
}

// Every prefix of a binary fixture is an error; every prefix of a text fixture is an error or
// a valid mesh; nothing crashes (run under the sanitizer build too).
TEST_F(Io, EveryPrefixOfEveryFixture) {
  for (const char* name :
       {"cube_binary.ply", "cube_binary_be.ply", "cube_binary.stl", "quads.glb", "quad.md2",
        "cube.obj", "cube_ascii.ply", "cube_ascii.stl", "cube.off", "quads.gltf", "quad.dae"}) {
    const std::string bytes = read_text(fixture(name));
    const bool binary = std::string(name).find("binary") != std::string::npos ||
                        std::string(name).ends_with(".glb") || std::string(name).ends_with(".md2");
    const std::string path = (dir() / name).string();
    for (std::size_t n = 0; n < bytes.size(); n += 1 + bytes.size() / 80) {
      write(dir(), name, bytes.substr(0, n));
      try {
        const Mesh mesh = load_mesh(path);
        EXPECT_FALSE(binary) << name << " cut to " << n << " bytes loaded";
        EXPECT_NO_THROW(mesh.validate(path));
      } catch (const Error& e) {
        EXPECT_TRUE(std::string(e.what()).starts_with(path + ":")) << e.what();
      }
    }
  }
}

// ---------------------------------------------------------------- wrong counts

TEST_F(Io, PlyHeaderDeclaresMoreVerticesAscii) {
  std::string text = read_text(fixture("cube_ascii.ply"));
  text.replace(text.find("vertex 8"), 8, "vertex 9");
  expect_mesh_error(file("more.ply", text), "header's counts");
}
TEST_F(Io, PlyHeaderDeclaresMoreVerticesBinary) {
  std::string bytes = read_text(fixture("cube_binary.ply"));
  bytes.replace(bytes.find("vertex 8"), 8, "vertex 9");
  expect_mesh_error(file("more.ply", bytes), "header's counts");
}
TEST_F(Io, PlyHeaderDeclaresMoreFaces) {
  std::string bytes = read_text(fixture("cube_binary.ply"));
  bytes.replace(bytes.find("face 6"), 6, "face 7");
  expect_mesh_error(file("more.ply", bytes), "truncated");
}
TEST_F(Io, PlyAbsurdVertexCount) {
  std::string bytes = read_text(fixture("cube_binary.ply"));
  bytes.replace(bytes.find("vertex 8"), 8, "vertex 4000000000");
  expect_mesh_error(file("absurd.ply", bytes), "truncated");
}
TEST_F(Io, BinaryStlHeaderCountTooLarge) {
  std::string bytes = read_text(fixture("cube_binary.stl"));
  const std::uint32_t count = 1000000;
  std::memcpy(bytes.data() + 80, &count, 4);
  expect_mesh_error(file("count.stl", bytes), "declares 1000000 triangles");
}
TEST_F(Io, OffHeaderDeclaresMoreFaces) {
  std::string text = read_text(fixture("cube.off"));
  text.replace(text.find("8 6 12"), 6, "8 7 12");
  expect_mesh_error(file("more.off", text), "truncated");
}
TEST_F(Io, Md2TrianglesBeyondTheFile) {
  std::string bytes = read_text(fixture("quad.md2"));
  const std::int32_t triangles = 100000;
  std::memcpy(bytes.data() + 32, &triangles, 4);
  expect_mesh_error(file("count.md2", bytes), "truncated");
}
TEST_F(Io, GltfIndexCountNotAMultipleOf3) {
  std::string text = read_text(fixture("quads.gltf"));
  const std::size_t at = text.find("\"count\": 6");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 10, "\"count\": 5");
  expect_mesh_error(file("count.gltf", text), "multiple of 3");
}
TEST_F(Io, ColladaAbsurdCountAttribute) {
  std::string text = read_text(fixture("quad.dae"));
  text.replace(text.find("count=\"12\""), 10, "count=\"4000000000\"");
  expect_mesh_error(file("count.dae", text), "count");
}

// ---------------------------------------------------------------- indices out of range

TEST_F(Io, ObjIndexOutOfRange) {
  expect_mesh_error(file("oob.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n"), "out of range");
}
TEST_F(Io, ObjRelativeIndexOutOfRange) {
  expect_mesh_error(file("oob.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n"), "relative");
}
TEST_F(Io, ObjIndexZero) {
  expect_mesh_error(file("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"), "start at 1");
}
TEST_F(Io, ObjNormalIndexOutOfRange) {  // assimp ignores this one
  expect_mesh_error(file("oob.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//2\n"),
                    "normal 2");
}
TEST_F(Io, ObjGarbageInAFace) {
  expect_mesh_error(file("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n"), "line 4");
}
TEST_F(Io, PlyIndexOutOfRange) {
  std::string text = read_text(fixture("cube_ascii.ply"));
  text.replace(text.find("4 0 3 2 1"), 9, "4 0 3 2 8");
  expect_mesh_error(file("oob.ply", text), "out of range");
}
TEST_F(Io, OffIndexOutOfRange) {  // assimp clamps this one to the last vertex
  std::string text = read_text(fixture("cube.off"));
  text.replace(text.find("4 0 3 2 1"), 9, "4 0 3 2 8");
  expect_mesh_error(file("oob.off", text), "out of range");
}
TEST_F(Io, Md2IndexOutOfRange) {  // assimp clamps this one too
  std::string bytes = read_text(fixture("quad.md2"));
  std::int32_t triangles_at;
  std::memcpy(&triangles_at, bytes.data() + 52, 4);
  const std::uint16_t bad = 40;
  std::memcpy(bytes.data() + triangles_at + 2, &bad, 2);
  expect_mesh_error(file("oob.md2", bytes), "out of range");
}
// Issue #23: MD2 keyframes are scaled by per-frame factors: a NaN or huge factor used to reach
// the structures (animate --refit crashed); every frame gets a loaded mesh's checks.
TEST_F(Io, Md2FrameWithNaNOrHugeScaleIsRefused) {
  for (const float scale : {std::numeric_limits<float>::quiet_NaN(), 1e35f}) {
    std::string bytes = read_text(fixture("quad.md2"));
    std::int32_t frames_at;
    std::memcpy(&frames_at, bytes.data() + 56, 4);
    std::memcpy(bytes.data() + frames_at, &scale, 4);  // the first frame's x scale
    const std::string path = file("scaled.md2", bytes);
    try {
      const FrameSequence frames({path});
      frames.load(0);
      ADD_FAILURE() << "an MD2 frame scaled by " << scale << " was accepted";
    } catch (const Error& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find("scaled.md2"), std::string::npos) << message;
      EXPECT_TRUE(message.find("NaN") != std::string::npos ||
                  message.find("beyond the limit") != std::string::npos)
          << message;
    }
    EXPECT_THROW(load_mesh(path), Error);
  }
}
TEST_F(Io, GltfIndexOutOfRange) {  // assimp drops the triangle with a log message
  std::string bin = read_text(fixture("quads_external.bin"));
  const std::uint16_t bad = 99;
  std::memcpy(bin.data() + 96 + 4, &bad, 2);
  file("quads_external.bin", bin);
  const std::string path = file("oob.gltf", read_text(fixture("quads_external.gltf")));
  expect_mesh_error(path, "out of range");
}
TEST_F(Io, ColladaIndexOutOfRange) {
  std::string text = read_text(fixture("quad.dae"));
  text.replace(text.find("<p>0 1 2 3</p>"), 14, "<p>0 1 2 9</p>");
  expect_mesh_error(file("oob.dae", text), "assimp");
}

// ---------------------------------------------------------------- hostile content

TEST_F(Io, ColladaGarbageInAnIndexList) {  // assimp 5.2 allocates without end on this one
  std::string text = read_text(fixture("quad.dae"));
  text.replace(text.find("<p>0 1 2 3</p>"), 14, "<p>0 1 x 3</p>");
  expect_mesh_error(file("garbage.dae", text), "not a number");
}
TEST_F(Io, ColladaArrayWithoutCount) {  // assimp 5.2 dereferences a null pointer on this one
  std::string text = read_text(fixture("quad.dae"));
  text.replace(text.find(" count=\"12\""), 11, "");
  expect_mesh_error(file("nocount.dae", text), "without a count");
}
TEST_F(Io, ColladaAccessorReadsPastItsArray) {  // assimp 5.2 reads garbage coordinates
  std::string text = read_text(fixture("quad.dae"));
  text.replace(text.find("count=\"12\">0 0 0 1 0 0 1 1 0 0 1 0"), 34, "count=\"3\">0 0 0");
  expect_mesh_error(file("short.dae", text), "reads 12 values but the array has 3");
}
TEST_F(Io, GltfDeepNodeChain) {  // would overflow the stack of assimp's recursive node reader
  nlohmann::json doc = nlohmann::json::parse(read_text(fixture("quads.gltf")));
  doc["nodes"] = nlohmann::json::array();
  for (int i = 0; i < 5000; ++i) doc["nodes"].push_back({{"children", {i + 1}}});
  doc["nodes"].push_back({{"mesh", 0}});
  expect_mesh_error(file("deep.gltf", doc.dump()), "deeper");
}
TEST_F(Io, GltfDeepJson) {
  std::string text = read_text(fixture("quads.gltf"));
  text.insert(text.rfind('}'),
              ",\"extras\":" + std::string(100000, '[') + std::string(100000, ']'));
  expect_mesh_error(file("deep.gltf", text), "deeper");
}
TEST_F(Io, GltfMissingExternalBuffer) {
  expect_mesh_error(file("lonely.gltf", read_text(fixture("quads_external.gltf"))),
                    "quads_external.bin");
}
TEST_F(Io, ObjWithANulByte) {
  expect_mesh_error(file("nul.obj", std::string("v 0 0 0\nv 1 0 0\0\nv 0 1 0\nf 1 2 3\n", 33)),
                    "NUL");
}

// ---------------------------------------------------------------- NaN and infinity

TEST_F(Io, NanInObj) {
  expect_mesh_error(file("nan.obj", "v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), "NaN");
}
TEST_F(Io, InfinityInObj) {  // 1e39 overflows a float
  expect_mesh_error(file("inf.obj", "v 0 0 1e39\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), "infinite");
}
TEST_F(Io, NanInBinaryPly) {
  std::string bytes = read_text(fixture("cube_binary.ply"));
  const float nan = std::nanf("");
  std::memcpy(bytes.data() + bytes.find("end_header\n") + 11 + 4, &nan, 4);
  expect_mesh_error(file("nan.ply", bytes), "NaN");
}
TEST_F(Io, InfinityInBinaryStl) {
  std::string bytes = read_text(fixture("cube_binary.stl"));
  const float inf = INFINITY;
  std::memcpy(bytes.data() + 84 + 12, &inf, 4);  // first vertex of the first triangle
  expect_mesh_error(file("inf.stl", bytes), "infinite");
}
TEST_F(Io, NanInOff) {
  std::string text = read_text(fixture("cube.off"));
  text.replace(text.find("1 1 1"), 5, "1 nan 1");
  expect_mesh_error(file("nan.off", text), "NaN");
}
TEST_F(Io, NodeTransformOverflowsToInfinity) {
  nlohmann::json doc = nlohmann::json::parse(read_text(fixture("quads.gltf")));
  doc["nodes"][0]["scale"] = {1e38, 1e38, 1e38};
  doc["nodes"][1]["scale"] = {1e38, 1e38, 1e38};
  expect_mesh_error(file("overflow.gltf", doc.dump()), "infinite");
}

// ---------------------------------------------------------------- no triangles

TEST_F(Io, ObjWithoutFaces) {
  expect_mesh_error(file("points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"), "no triangles");
}
TEST_F(Io, ObjWithOnlyLines) {
  expect_mesh_error(file("lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\n"), "no triangles");
}
TEST_F(Io, PlyPointCloud) {
  std::string text = read_text(fixture("cube_ascii.ply"));
  text.replace(text.find("face 6"), 6, "face 0");
  expect_mesh_error(file("cloud.ply", text.substr(0, text.find("4 0 3 2 1"))), "no triangles");
}
TEST_F(Io, BinaryStlWithZeroTriangles) {
  expect_mesh_error(file("zero.stl", std::string(84, '\0')), "no triangles");
}

// ---------------------------------------------------------------- gzip

TEST_F(Io, CorruptGzip) {
  std::string bytes = gzip(read_text(fixture("cube.obj")));
  for (std::size_t i = 12; i < 30; ++i) bytes[i] = static_cast<char>(bytes[i] ^ 0x5a);
  expect_mesh_error(file("corrupt.obj.gz", bytes), "corrupt gzip");
}
TEST_F(Io, TruncatedGzip) {
  const std::string bytes = gzip(read_text(fixture("cube.obj")));
  expect_mesh_error(file("cut.obj.gz", bytes.substr(0, bytes.size() - 12)), "truncated gzip");
}
TEST_F(Io, NotGzipAtAll) {
  expect_mesh_error(file("plain.obj.gz", read_text(fixture("cube.obj"))), "not gzip");
}
TEST_F(Io, GzipWithTrailingGarbage) {
  expect_mesh_error(file("trailing.obj.gz", gzip(read_text(fixture("cube.obj"))) + "garbage"),
                    "after the end");
}
TEST_F(Io, GzipOfNothing) { expect_mesh_error(file("nothing.obj.gz", gzip("")), "empty"); }

TEST(IoGzip, DecompressionStopsAtTheLimit) {
  // 8 MiB of zeros compress to a few KiB: a small bomb against a 1 MiB limit.
  const std::string bomb = gzip(std::string(8 << 20, '\0'));
  const std::span<const unsigned char> bytes(reinterpret_cast<const unsigned char*>(bomb.data()),
                                             bomb.size());
  expect_error([&] { gunzip(bytes, "bomb.obj.gz", 1 << 20); }, "bomb.obj.gz", "limit");
  EXPECT_EQ(gunzip(bytes, "bomb.obj.gz", 8 << 20).size(),
            std::size_t{8} << 20);  // exactly at the limit
  EXPECT_EQ(kMaxInputBytes, std::size_t{2} << 30);
}

// ---------------------------------------------------------------- JSON scenes

TEST(IoScene, FixtureSceneLoads) {
  const Scene scene = load_scene(fixture("scene.json"));
  EXPECT_EQ(scene.meshes.size(), 2u);  // cube.obj is loaded once for its three instances
  ASSERT_EQ(scene.instances.size(), 4u);
  ASSERT_EQ(scene.materials.size(), 3u);  // default, red, glass
  EXPECT_EQ(scene.materials[1].name, "red");
  EXPECT_EQ(scene.materials[1].diffuse, (Vec3{0.8f, 0.1f, 0.1f}));
  EXPECT_EQ(scene.materials[1].specular, Vec3(0.3f));
  EXPECT_EQ(scene.materials[1].shininess, 64);
  EXPECT_EQ(scene.materials[2].transparency, 0.9f);
  EXPECT_EQ(scene.materials[2].reflectivity, 0.1f);
  EXPECT_TRUE(scene.materials[2].fresnel);
  EXPECT_EQ(scene.instances[0].material, 1u);
  EXPECT_EQ(scene.instances[1].material, 2u);
  EXPECT_FALSE(scene.instances[2].material.has_value());  // the mesh's own, or "default"
  ASSERT_EQ(scene.lights.size(), 2u);
  EXPECT_EQ(scene.lights[0].kind, Light::Kind::point);
  EXPECT_EQ(scene.lights[0].intensity, 150);
  EXPECT_EQ(scene.lights[1].kind, Light::Kind::directional);
  EXPECT_NEAR(length(scene.lights[1].direction), 1.0f, 1e-6f);
  EXPECT_EQ(scene.lights[1].color, Vec3(0.5f));
  ASSERT_TRUE(scene.camera.has_value());
  EXPECT_EQ(scene.camera->eye, (Vec3{3, 4, 12}));
  EXPECT_EQ(scene.camera->vfov_degrees, 40);
  EXPECT_EQ(scene.background, (Vec3{0.1f, 0.2f, 0.3f}));
  EXPECT_EQ(scene.ambient, Vec3(0.05f));

  const FlatScene flat = flatten(scene);
  ASSERT_EQ(flat.triangles.size(), 12u + 12u + 4u + 12u);
  auto part = [&](std::size_t begin, std::size_t count) {
    return bounds({flat.triangles.begin() + begin, flat.triangles.begin() + begin + count});
  };
  expect_box(part(0, 12), {0, 0, 0}, {1, 1, 1});
  expect_box(part(12, 12), {5, 0, 0}, {7, 2, 2});  // scale 2, then translate
  // quads.glb spans (10,0,0)-(11,1,6); 90 degrees about y maps (x,y,z) to (z,y,-x).
  expect_box(part(24, 4), {0, 0, -31}, {6, 1, -30});
  expect_box(part(28, 12), {0, 10, 0}, {1, 11, 1});  // 3x4 matrix
  EXPECT_EQ(flat.material[12], 2u);
}

class IoSceneFile : public Io {
 protected:
  // A scene file in the test's folder; the mesh named "cube.obj" sits beside it.
  std::string scene(const std::string& json) {
    if (!fs::exists(dir() / "cube.obj")) fs::copy_file(fixture("cube.obj"), dir() / "cube.obj");
    return file("scene.json", json);
  }
  void expect_scene_error(const std::string& json, const std::string& word) {
    const std::string path = scene(json);
    expect_error([&] { load_scene(path); }, path, word);
  }
};

TEST_F(IoSceneFile, TransformStepsApplyInOrder) {
  const Scene a = load_scene(scene(
      R"({"instances": [{"mesh": "cube.obj", "transform": [{"scale": 2}, {"translate": [1, 0, 0]}]}]})"));
  expect_box(bounds(flatten(a).triangles), {1, 0, 0}, {3, 2, 2});
  const Scene b = load_scene(scene(
      R"({"instances": [{"mesh": "cube.obj", "transform": [{"translate": [1, 0, 0]}, {"scale": 2}]}]})"));
  expect_box(bounds(flatten(b).triangles), {2, 0, 0}, {4, 2, 2});
}

TEST_F(IoSceneFile, MatrixForms) {
  const Scene s = load_scene(scene(R"({"instances": [
      {"mesh": "cube.obj", "transform": {"matrix": [1,0,0,3, 0,1,0,0, 0,0,1,0, 0,0,0,1]}},
      {"mesh": "cube.obj", "transform": {"rotate": {"axis": [0, 0, 1], "degrees": 90}}}]})"));
  const FlatScene flat = flatten(s);
  expect_box(bounds({flat.triangles.begin(), flat.triangles.begin() + 12}), {3, 0, 0}, {4, 1, 1});
  expect_box(bounds({flat.triangles.begin() + 12, flat.triangles.end()}), {-1, 0, 0}, {0, 1, 1},
             1e-6f);
}

TEST_F(IoSceneFile, Defaults) {
  const Scene s = load_scene(scene(R"({"instances": [{"mesh": "cube.obj"}]})"));
  EXPECT_EQ(s.materials.size(), 1u);
  EXPECT_TRUE(s.lights.empty());  // lights fitted to the view, as for a mesh file
  EXPECT_TRUE(s.lights_fit_view);
  EXPECT_TRUE(s.camera.has_value());  // framed around the scene
  const Scene dark = load_scene(scene(R"({"instances": [{"mesh": "cube.obj"}], "lights": []})"));
  EXPECT_TRUE(dark.lights.empty());
  EXPECT_FALSE(dark.lights_fit_view);
  const Scene redefined = load_scene(scene(R"({"materials": [{"name": "default", "diffuse": 0.2}],
                                               "instances": [{"mesh": "cube.obj"}]})"));
  ASSERT_EQ(redefined.materials.size(), 1u);
  EXPECT_EQ(redefined.materials[0].diffuse, Vec3(0.2f));
}

TEST_F(IoSceneFile, AbsoluteMeshPath) {
  const Scene s =
      load_scene(scene(R"({"instances": [{"mesh": ")" + fixture("cube.off") + R"("}]})"));
  EXPECT_EQ(s.meshes.at(0).triangle_count(), 12u);
}

TEST_F(IoSceneFile, Gzipped) {
  scene("");  // puts cube.obj beside it
  const std::string path = file("scene.json.gz", gzip(R"({"instances": [{"mesh": "cube.obj"}]})"));
  EXPECT_EQ(load_scene(path).instances.size(), 1u);
}

TEST_F(IoSceneFile, NotThere) {
  const std::string path = (dir() / "none.json").string();
  expect_error([&] { load_scene(path); }, path, "no such file");
}
TEST_F(IoSceneFile, InvalidJson) { expect_scene_error(R"({"instances": [)", "invalid JSON"); }
TEST_F(IoSceneFile, NestedTooDeep) {
  expect_scene_error(R"({"instances": [{"mesh": "cube.obj"}], "x": )" + std::string(100, '[') +
                         std::string(100, ']') + "}",
                     "deeper than 64");
}
TEST_F(IoSceneFile, NotAnObject) { expect_scene_error(R"([1, 2])", "expected an object"); }
TEST_F(IoSceneFile, DuplicateKey) {
  expect_scene_error(R"({"instances": [{"mesh": "cube.obj", "mesh": "cube.obj"}]})",
                     "duplicate key 'mesh'");
}
TEST_F(IoSceneFile, UnknownTopLevelKey) {
  expect_scene_error(R"({"instances": [{"mesh": "cube.obj"}], "lighting": []})",
                     "unknown key 'lighting'");
}
TEST_F(IoSceneFile, UnknownNestedKey) {
  expect_scene_error(R"({"instances": [{"mesh": "cube.obj", "transform": [{"rotat": 1}]}]})",
                     "instances[0].transform[0]: unknown key 'rotat'");
}
TEST_F(IoSceneFile, UnknownMaterialKey) {
  expect_scene_error(
      R"({"materials": [{"name": "m", "colour": 1}], "instances": [{"mesh": "cube.obj"}]})",
      "materials[0]: unknown key 'colour'");
}
TEST_F(IoSceneFile, IntensityOnADirectionalLight) {
  expect_scene_error(R"({"instances": [{"mesh": "cube.obj"}],
                         "lights": [{"type": "directional", "direction": [0, -1, 0], "intensity": 2}]})",
                     "lights[0]: unknown key 'intensity'");
}
TEST_F(IoSceneFile, MissingInstances) {
  expect_scene_error(R"({"lights": []})", "missing required key 'instances'");
}
TEST_F(IoSceneFile, NoInstances) {
  expect_scene_error(R"({"instances": []})", "at least one instance");
}
TEST_F(IoSceneFile, MissingMesh) {
  expect_scene_error(R"({"instances": [{"material": "default"}]})", "'mesh'");
}
TEST_F(IoSceneFile, MissingCameraEye) {
  expect_scene_error(R"({"instances": [{"mesh": "cube.obj"}], "camera": {"target": [0, 0, 0]}})",
                     "camera: missing required key 'eye'");
}
TEST_F(IoSceneFile, MissingLightType) {
  expect_scene_error(
      R"({"instances": [{"mesh": "cube.obj"}], "lights": [{"position": [0, 1, 0]}]})",
      "lights[0]: missing required key 'type'");
}
TEST_F(IoSceneFile, MissingMaterialName) {
  expect_scene_error(R"({"materials": [{"diffuse": 1}], "instances": [{"mesh": "cube.obj"}]})",
                     "materials[0]: missing required key 'name'");
}
TEST_F(IoSceneFile, WrongTypeNumber) {
  expect_scene_error(
      R"({"instances": [{"mesh": "cube.obj"}], "camera": {"eye": [0, 0, 5], "target": [0, 0, 0], "fov": "wide"}})",
      "camera.fov: expected a number, got a string");
}
TEST_F(IoSceneFile, WrongTypeVector) {
  expect_scene_error(
      R"({"instances": [{"mesh": "cube.obj"}], "camera": {"eye": [0, 5], "target": [0, 0, 0]}})",
      "camera.eye: expected an array of 3 numbers");
}
TEST_F(IoSceneFile, WrongTypeInstances) {
  expect_scene_error(R"({"instances": {"mesh": "cube.obj"}})",
                     "instances: expected an array, got an object");
}
TEST_F(IoSceneFile, WrongTypeBoolean) {
  expect_scene_error(
      R"({"materials": [{"name": "m", "fresnel": 1}], "instances": [{"mesh": "cube.obj"}]})",
      "materials[0].fresnel: expected true or false");
}
TEST_F(IoSceneFile, ValueOutOfRange) {
  expect_scene_error(
      R"({"materials": [{"name": "m", "reflectivity": 2}], "instances": [{"mesh": "cube.obj"}]})",
      "materials[0].reflectivity: must be between 0 and 1");
}
TEST_F(IoSceneFile, NegativeColour) {
  expect_scene_error(R"({"instances": [{"mesh": "cube.obj"}], "background": [0, -1, 0]})",
                     "must not be negative");
}
TEST_F(IoSceneFile, UnknownMaterial) {
  expect_scene_error(R"({"instances": [{"mesh": "cube.obj", "material": "gold"}]})",
                     "unknown material 'gold'");
}
TEST_F(IoSceneFile, DuplicateMaterial) {
  expect_scene_error(
      R"({"materials": [{"name": "m"}, {"name": "m"}], "instances": [{"mesh": "cube.obj"}]})",
      "duplicate material name 'm'");
}
TEST_F(IoSceneFile, UnknownLightType) {
  expect_scene_error(
      R"({"instances": [{"mesh": "cube.obj"}], "lights": [{"type": "spot", "position": [0, 1, 0]}]})",
      "unknown light type 'spot'");
}
TEST_F(IoSceneFile, ZeroScale) {
  expect_scene_error(R"({"instances": [{"mesh": "cube.obj", "transform": {"scale": [1, 0, 1]}}]})",
                     "must not be zero");
}
TEST_F(IoSceneFile, SingularMatrix) {
  expect_scene_error(
      R"({"instances": [{"mesh": "cube.obj", "transform": {"matrix": [1,0,0,0, 1,0,0,0, 0,0,1,0]}}]})",
      "singular");
}
TEST_F(IoSceneFile, ProjectiveMatrix) {
  expect_scene_error(
      R"({"instances": [{"mesh": "cube.obj", "transform": {"matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,1,1]}}]})",
      "0 0 0 1");
}
TEST_F(IoSceneFile, TwoKeysInOneTransformStep) {
  expect_scene_error(
      R"({"instances": [{"mesh": "cube.obj", "transform": {"scale": 2, "translate": [1, 0, 0]}}]})",
      "exactly one");
}
TEST_F(IoSceneFile, NumberTooLargeForAFloat) {
  expect_scene_error(
      R"({"instances": [{"mesh": "cube.obj", "transform": {"translate": [1e39, 0, 0]}}]})",
      "too large");
}
TEST_F(IoSceneFile, MeshFileMissing) {
  const std::string path = scene(R"({"instances": [{"mesh": "cube.obj"}, {"mesh": "gone.obj"}]})");
  expect_error([&] { load_scene(path); }, path,
               "instances[1].mesh: " + (dir() / "gone.obj").string() + ": no such file");
}
TEST_F(IoSceneFile, MeshFileBroken) {
  file("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99\n");
  expect_scene_error(R"({"instances": [{"mesh": "bad.obj"}]})",
                     "bad.obj: line 4: face refers to vertex 99");
}

}  // namespace
}  // namespace splitray

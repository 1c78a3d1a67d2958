// Structures built from the caller's strided buffers (MeshBuffers) and MeshScene: the same hits
// as from a triangle soup, normals of the caller's vertices, updates along a real animation,
// and every invalid buffer refused with a message.
#include "splitray/accel/mesh_scene.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <random>
#include <vector>

#include "splitray/core/errors.hpp"
#include "splitray/io/frames.hpp"
#include "splitray/io/mesh_io.hpp"
#include "test_data.hpp"

namespace splitray {
namespace {

// A mesh interleaved as applications keep it: position, a pad and a normal per vertex (28
// bytes), and indices with a material id after each triangle (16 bytes).
struct Interleaved {
  struct Vertex {
    float position[3];
    float pad;
    float normal[3];
  };
  std::vector<Vertex> vertices;
  std::vector<std::uint32_t> indices;  // 4 per triangle

  explicit Interleaved(const Mesh& mesh) {
    for (const Vec3& p : mesh.positions) vertices.push_back({{p.x, p.y, p.z}, 0, {0, 0, 1}});
    for (const auto& f : mesh.faces) indices.insert(indices.end(), {f[0], f[1], f[2], 7});
  }
  MeshBuffers buffers() const {
    return {vertices.data(), vertices.size(),    sizeof(Vertex),
            indices.data(),  indices.size() / 4, 4 * sizeof(std::uint32_t)};
  }
};

std::vector<Ray> rays_around(const Aabb& box, std::size_t n, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> g;
  const Vec3 c = box.center(), s = box.hi - box.lo;
  std::vector<Ray> rays(n);
  for (Ray& r : rays) {
    r.org = c + Vec3{g(rng) * s.x, g(rng) * s.y, g(rng) * s.z};
    r.dir = c + Vec3{g(rng) * s.x, g(rng) * s.y, g(rng) * s.z} * 0.2f - r.org;
  }
  return rays;
}

TEST(MeshScene, StridedBuffersGiveTheHitsOfTheSoupWithNormals) {
  const Mesh mesh = load_mesh(test::vendored_file("horse/horse.obj.gz"));
  const Interleaved data(mesh);
  const std::vector<Triangle> soup = mesh.triangles();
  const std::vector<Ray> rays = rays_around(mesh.bounds(), 4000, 3);
  const auto brute = make_accel("brute", soup);
  std::size_t hits = 0;
  for (const char* accel : {"bvh", "kd", "bih", "brute"}) {
    const MeshScene scene(data.buffers(), accel);
    std::vector<SurfaceHit> found(rays.size());
    scene.intersect(rays, found);
    for (std::size_t i = 0; i < rays.size(); ++i) {
      const Hit expected = brute->intersect(rays[i]);
      ASSERT_EQ(found[i].prim, expected.prim) << accel << " ray " << i;
      ASSERT_EQ(found[i].t, expected.t) << accel << " ray " << i;
      const Vec3 ng = expected.found() ? soup[expected.prim].geometric_normal() : Vec3{0};
      ASSERT_EQ(found[i].ng, ng) << accel << " ray " << i;
      ASSERT_EQ(scene.intersect(rays[i]).prim, expected.prim);
      hits += expected.found();
    }
  }
  EXPECT_GT(hits, 4000u);  // the rays do hit the horse
}

TEST(MeshScene, UpdatesFollowARealAnimation) {
  SPLITRAY_REQUIRE_SHARED(first, "anim_horse_collapse/frames/horse-collapse-01.obj.gz");
  std::vector<Mesh> frames;
  for (const char* name : {"01", "02", "03", "04"})
    frames.push_back(load_mesh(test::shared_file(
        std::string("anim_horse_collapse/frames/horse-collapse-") + name + ".obj.gz")));
  for (const auto& [accel, expected] : {std::pair{"bvh", MeshUpdate::refit},
                                        {"kd", MeshUpdate::predicted_rebuild},
                                        {"bih", MeshUpdate::rebuild}}) {
    Interleaved data(frames[0]);
    MeshScene scene(data.buffers(), accel);
    for (std::size_t f = 1; f < frames.size(); ++f) {
      // The kept buffers stay alive until update() has moved the scene to the new ones.
      Interleaved next(frames[f]);
      EXPECT_EQ(scene.update(next.buffers()), expected) << accel;
      data = std::move(next);  // moved vectors keep their memory: the scene's buffers stay valid
      const std::vector<Triangle> soup = frames[f].triangles();
      const auto brute = make_accel("brute", soup);
      for (const Ray& ray : rays_around(frames[f].bounds(), 1000, unsigned(f))) {
        const SurfaceHit hit = scene.intersect(ray);
        const Hit want = brute->intersect(ray);
        ASSERT_EQ(hit.prim, want.prim) << accel << " frame " << f;
        ASSERT_EQ(hit.t, want.t) << accel << " frame " << f;
        // The normals follow the update (the scene keeps its own per-triangle copy).
        const Vec3 ng = want.found() ? soup[want.prim].geometric_normal() : Vec3{0};
        ASSERT_EQ(hit.ng, ng) << accel << " frame " << f;
      }
    }
  }
}

void expect_refused(const MeshBuffers& buffers, const std::string& words) {
  try {
    MeshScene scene(buffers, "bvh", {}, "my mesh");
    FAIL() << "accepted; expected: " << words;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("my mesh: " + words), std::string::npos) << e.what();
  }
}

TEST(MeshScene, InvalidBuffersAreRefusedWithAMessage) {
  const float v[] = {0, 0, 0, 1, 0, 0, 0, 1, 0, NAN, 0, 0};
  const std::uint32_t good[] = {0, 1, 2}, far[] = {0, 1, 4}, nan[] = {0, 1, 3};
  expect_refused({v, 4, 12, far, 1, 12},
                 "vertex index 4 of triangle 0 is out of range (4 vertices)");
  expect_refused({v, 4, 12, nan, 1, 12}, "vertex 3 of triangle 0 has a non-finite coordinate");
  expect_refused({v, 4, 12, good, 0, 12}, "no triangles");
  expect_refused({nullptr, 4, 12, good, 1, 12}, "null vertex or index buffer");
  expect_refused({v, 4, 8, good, 1, 12}, "vertex stride 8 or index stride 12 is smaller");
  MeshScene scene({v, 3, 12, good, 1, 12});
  const std::uint32_t other[] = {0, 2, 1};
  EXPECT_THROW(scene.update({v, 3, 12, other, 1, 12}), Error);  // other triangles
  EXPECT_THROW(scene.update({v, 4, 12, good, 1, 12}), Error);   // other vertex count
}

}  // namespace
}  // namespace splitray

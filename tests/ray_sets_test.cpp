// Ray sets: reproducible from the seed, independent of the thread count, of the kind asked.
#include "splitray/render/ray_sets.hpp"

#include <gtest/gtest.h>

#include <cstring>

#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/render/shapes.hpp"
#include "splitray/render/surface.hpp"
#include "test_data.hpp"

namespace splitray {
namespace {

// A sphere standing on a floor: surfaces facing many ways, and rays that miss.
std::vector<Triangle> sphere_on_floor() {
  std::vector<Triangle> tris = make_icosphere(2).triangles();
  for (Triangle& t : tris)
    for (Vec3* v : {&t.v0, &t.v1, &t.v2}) *v = *v + Vec3{0, 1, 0};
  for (const Triangle& t : make_quad({-3, 0, 3}, {6, 0, 0}, {0, 0, -6}).triangles())
    tris.push_back(t);
  return tris;
}

bool same_rays(const std::vector<Ray>& a, const std::vector<Ray>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Ray)) == 0;
}

// Closest point on triangle t to p (Ericson, Real-Time Collision Detection 5.1.5).
Vec3 closest_point(const Triangle& t, const Vec3& p) {
  const Vec3 ab = t.v1 - t.v0, ac = t.v2 - t.v0, ap = p - t.v0;
  const float d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return t.v0;
  const Vec3 bp = p - t.v1;
  const float d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return t.v1;
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return t.v0 + ab * (d1 / (d1 - d3));
  const Vec3 cp = p - t.v2;
  const float d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return t.v2;
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return t.v0 + ac * (d2 / (d2 - d6));
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)
    return t.v1 + (t.v2 - t.v1) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const float denom = 1 / (va + vb + vc);
  return t.v0 + ab * (vb * denom) + ac * (vc * denom);
}

TEST(RaySets, ParsesKindNamesAndRejectsUnknownOnes) {
  EXPECT_EQ(parse_ray_kind("primary"), RayKind::primary);
  EXPECT_EQ(parse_ray_kind("random"), RayKind::random);
  EXPECT_EQ(parse_ray_kind("diffuse"), RayKind::diffuse);
  try {
    parse_ray_kind("shadow");
    FAIL() << "expected an Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'shadow'"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("primary"), std::string::npos);  // lists the known kinds
  }
  EXPECT_THROW(parse_ray_kind(""), Error);
  EXPECT_THROW(parse_ray_kind("Primary"), Error);
}

TEST(RaySets, SameSeedSameRaysOtherSeedOtherRays) {
  const auto tris = sphere_on_floor();
  for (RayKind kind : {RayKind::primary, RayKind::random, RayKind::diffuse}) {
    const auto a = make_rays(tris, kind, 7, 3000);
    const auto b = make_rays(tris, kind, 7, 3000);
    const auto c = make_rays(tris, kind, 8, 3000);
    ASSERT_EQ(a.size(), 3000u);
    EXPECT_TRUE(same_rays(a, b)) << static_cast<int>(kind);
    EXPECT_FALSE(same_rays(a, c)) << static_cast<int>(kind);
    for (const Ray& r : a) {
      ASSERT_TRUE(is_finite(r.org) && is_finite(r.dir));
      ASSERT_NEAR(length(r.dir), 1.0f, 1e-5f);
    }
  }
}

TEST(RaySets, IndependentOfTheThreadCount) {
  const auto tris = sphere_on_floor();
  for (RayKind kind : {RayKind::primary, RayKind::random, RayKind::diffuse}) {
    std::vector<Ray> one, two;
    {
      ThreadLimit limit(1);
      one = make_rays(tris, kind, 42, 5000);
    }
    {
      ThreadLimit limit(2);
      two = make_rays(tris, kind, 42, 5000);
    }
    EXPECT_TRUE(same_rays(one, two)) << static_cast<int>(kind);
  }
}

TEST(RaySets, PrimaryRaysLeaveTheCameraAndCoverTheImage) {
  const auto tris = sphere_on_floor();
  Camera camera;
  camera.eye = {0, 1, 8};
  camera.target = {0, 1, 0};
  const auto rays = make_rays(tris, RayKind::primary, 1, 1200, camera);
  float min_x = 1, max_x = -1, min_y = 1, max_y = -1;
  for (const Ray& r : rays) {
    ASSERT_EQ(r.org, camera.eye);
    min_x = std::min(min_x, r.dir.x), max_x = std::max(max_x, r.dir.x);
    min_y = std::min(min_y, r.dir.y), max_y = std::max(max_y, r.dir.y);
  }
  // A 60 degree field of view, 4:3: the grid spans it from edge to edge.
  EXPECT_LT(min_x, -0.55f);
  EXPECT_GT(max_x, 0.55f);
  EXPECT_LT(min_y, -0.4f);
  EXPECT_GT(max_y, 0.4f);
}

TEST(RaySets, RandomRaysStartInsideTheBounds) {
  const auto tris = sphere_on_floor();
  const Aabb box = bounds_of(tris);
  Vec3 mean_dir{0};
  const auto rays = make_rays(tris, RayKind::random, 3, 4000);
  for (const Ray& r : rays) {
    ASSERT_TRUE(box.contains(r.org));
    mean_dir += r.dir;
  }
  EXPECT_LT(length(mean_dir / 4000.0f), 0.05f);  // uniform directions average out
}

TEST(RaySets, DiffuseRaysStartOnSurfacesAndLeaveThem) {
  const auto tris = sphere_on_floor();
  const float eps = offset_epsilon(bounds_of(tris));
  const auto rays = make_rays(tris, RayKind::diffuse, 5, 2000);
  for (const Ray& r : rays) {
    float best = kInfinity;
    std::size_t nearest = 0;
    for (std::size_t i = 0; i < tris.size(); ++i) {
      const float d = length(closest_point(tris[i], r.org) - r.org);
      if (d < best) best = d, nearest = i;
    }
    ASSERT_LE(best, 1.01f * eps) << "a diffuse ray starts off every surface";
    // The ray leaves on the side its origin was offset to.
    const Vec3 n = tris[nearest].geometric_normal();
    EXPECT_GT(dot(n, r.org - tris[nearest].v0) * dot(n, r.dir), 0);
  }
}

TEST(RaySets, DiffuseRaysNeedACameraThatSeesTheScene) {
  const auto tris = sphere_on_floor();
  Camera away;
  away.eye = {0, 1, 10};
  away.target = {0, 1, 20};
  EXPECT_THROW(make_rays(tris, RayKind::diffuse, 1, 10, away), Error);
  EXPECT_THROW(make_rays({}, RayKind::primary, 1, 10), Error);
}

TEST(RaySets, DiffuseRaysOnTheVendoredHorse) {
  const Mesh horse = load_mesh(test::vendored_file("horse/horse.obj.gz"));
  const auto tris = horse.triangles();
  const auto rays = make_rays(tris, RayKind::diffuse, 11, 4000);
  ASSERT_EQ(rays.size(), 4000u);
  const Aabb box = bounds_of(tris);
  const float eps = offset_epsilon(box);
  Aabb grown = box;
  grown.extend(box.lo - Vec3{2 * eps});
  grown.extend(box.hi + Vec3{2 * eps});
  for (const Ray& r : rays) ASSERT_TRUE(grown.contains(r.org));
}

}  // namespace
}  // namespace splitray

// The ray and coordinate domain of coordinates.hpp (issue #23): rays with NaN or inf
// components, zero directions or far origins miss in every structure (single and batched,
// alone or mixed into a batch of good rays, which keep their brute-force answers); directions
// of any length give the hits of the same ray with a unit-scale direction; meshes beyond the
// coordinate limit are refused at build and refit; a mesh at the limit is traced exactly.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "hierarchy_oracle.hpp"
#include "splitray/core/coordinates.hpp"
#include "splitray/core/errors.hpp"

namespace splitray {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

const std::vector<Triangle>& horse() {
  static const std::vector<Triangle> tris =
      test::load_triangles(test::vendored_file("horse/horse.obj.gz"));
  return tris;
}

std::vector<Ray> untraceable_rays(const Aabb& box) {
  const Vec3 c = box.center();
  const Vec3 far_away{0x1p41f, 0, 0};
  return {
      Ray{Vec3{kNaN, c.y, c.z}, Vec3{1, 0, 0}},
      Ray{c, Vec3{kNaN, 0, 1}},
      Ray{c, Vec3{0, 0, 0}},
      Ray{c, Vec3{kInfinity, 1, 1}},
      Ray{Vec3{-kInfinity, c.y, c.z}, Vec3{1, 0, 0}},
      Ray{c + far_away, Vec3{-1, 0, 0}},  // aimed at the mesh from beyond the origin limit
      Ray{c, Vec3{1, 1, 1}, kNaN, kInfinity},
      Ray{c, Vec3{1, 1, 1}, 0, kNaN},
      Ray{c, Vec3{0, -1, 0}, 0, -kInfinity},
  };
}

// Every structure the registry builds, on the same triangles; Embree, whose own triangle
// test is not brute force's, only where answers are compared as hit or miss.
std::vector<std::unique_ptr<Accel>> every_structure(const std::vector<Triangle>& tris,
                                                    bool with_embree = false) {
  std::vector<std::unique_ptr<Accel>> all;
  for (const std::string& name : accel_names())
    if (with_embree || name != "embree") all.push_back(make_accel(name, tris));
  return all;
}

TEST(RayDomain, UntraceableRaysMissInEveryStructureAndGoodRaysKeepTheirAnswers) {
  const auto& tris = horse();
  const Aabb box = test::bounds_of(tris);
  const std::vector<Ray> bad = untraceable_rays(box);
  // Good rays with a bad one after every fourth in the first half, so packets and chunks mix
  // both, and good rays alone in the second half (the batched calls' blocks of either kind).
  const std::vector<Ray> good = test::hard_rays(tris, 4096, 23);
  std::vector<Ray> mixed;
  std::vector<bool> is_bad;
  for (std::size_t i = 0; i < good.size(); ++i) {
    mixed.push_back(good[i]);
    is_bad.push_back(false);
    if (i % 4 == 3 && i < good.size() / 2) {
      mixed.push_back(bad[i % bad.size()]);
      is_bad.push_back(true);
    }
  }
  const test::Answers brute = test::brute_answers(tris, good);
  for (const auto& accel : every_structure(tris, true)) {
    const std::string name = accel->stats().accel;
    for (const Ray& ray : bad) {
      EXPECT_FALSE(accel->intersect(ray).found()) << name;
      EXPECT_FALSE(accel->occluded(ray)) << name;
    }
    const test::Answers got = test::answers_of(*accel, mixed);
    test::Answers kept;
    for (std::size_t i = 0; i < mixed.size(); ++i) {
      if (is_bad[i]) {
        EXPECT_FALSE(got.hits[i].found()) << name << " ray " << i;
        EXPECT_EQ(got.hits[i].t, kInfinity) << name << " ray " << i;
        EXPECT_EQ(got.occluded[i], 0) << name << " ray " << i;
      } else {
        kept.hits.push_back(got.hits[i]);
        kept.occluded.push_back(got.occluded[i]);
      }
    }
    if (name != "embree")
      test::expect_same_answers(brute, kept, good, name + " (good rays among bad ones)");
  }
}

TEST(RayDomain, TheBatchedTestOfRaysAsGivenAgreesWithTheRule) {
  // Every field of a good ray set to values on and beyond the edges of the domain, the ray
  // placed at every position of batches of 1 to 5 (the SIMD test takes rays two at a time).
  const auto rule = [](const std::vector<Ray>& rays) {
    for (const Ray& r : rays)
      if (!traceable(r) || direction_exponent(r) != 0) return false;
    return true;
  };
  const Ray good{Vec3{1, -2, 3}, Vec3{0.5f, -0.1f, 0.2f}, 0, kInfinity};
  const float values[] = {kNaN,
                          kInfinity,
                          -kInfinity,
                          0,
                          -0.0f,
                          0x1p-2f,
                          std::nextafter(0x1p-2f, 0.0f),
                          -0x1p-2f,
                          0x1p2f,
                          std::nextafter(0x1p2f, kInfinity),
                          -0x1p2f,
                          kMaxRayOrigin,
                          std::nextafter(kMaxRayOrigin, kInfinity),
                          -kMaxRayOrigin,
                          1e-30f};
  std::size_t cases = 0, accepted = 0;
  for (int field = 0; field < 8; ++field)
    for (const float value : values) {
      Ray odd = good;
      float* floats = &odd.org.x;
      floats[field] = value;
      if (field >= 3 && field < 6) {  // also with the other direction components small
        for (int other = 3; other < 6; ++other)
          if (other != field) floats[other] = 0.01f;
      }
      for (std::size_t n = 1; n <= 5; ++n)
        for (std::size_t at = 0; at < n; ++at) {
          std::vector<Ray> rays(n, good);
          rays[at] = odd;
          EXPECT_EQ(all_as_given(rays), rule(rays))
              << "field " << field << " = " << value << ", ray " << at << " of " << n;
          ++cases;
          accepted += rule(rays) ? 1 : 0;
        }
    }
  EXPECT_GT(accepted, cases / 5);  // both answers occur
  EXPECT_LT(accepted, cases * 4 / 5);
  EXPECT_TRUE(all_as_given({}));
}

TEST(RayDomain, DirectionLengthDoesNotChangeTheHit) {
  const auto& tris = horse();
  std::vector<Ray> unit = test::hard_rays(tris, 2048, 7);
  for (Ray& r : unit) {
    const float m = max_component(abs(r.dir));
    const float s = std::ldexp(1.0f, -std::ilogb(m));  // largest component in [1, 2)
    r = Ray{r.org, r.dir * s, r.tmin / s, r.tmax / s};
  }
  const test::Answers expected = test::brute_answers(tris, unit);
  for (const int exponent : {-60, -20, -3, 3, 20, 60}) {
    std::vector<Ray> scaled;
    for (const Ray& r : unit) {
      const float s = std::ldexp(1.0f, exponent);
      scaled.push_back(Ray{r.org, r.dir * s, r.tmin / s, r.tmax / s});
    }
    for (const auto& accel : every_structure(tris)) {
      const std::string what =
          accel->stats().accel + " with directions times 2^" + std::to_string(exponent);
      test::Answers got = test::answers_of(*accel, scaled);
      for (Hit& h : got.hits)
        if (h.found()) h.t = std::ldexp(h.t, exponent);  // back to the unit direction's t
      test::expect_same_answers(expected, got, unit, what);
      for (std::size_t i = 0; i < scaled.size(); i += 97)  // the single-ray call agrees
        EXPECT_TRUE(test::same_hit(got.hits[i].found()
                                       ? Hit{std::ldexp(got.hits[i].t, -exponent), got.hits[i].prim,
                                             got.hits[i].u, got.hits[i].v}
                                       : got.hits[i],
                                   accel->intersect(scaled[i])))
            << what << " ray " << i;
    }
  }
}

TEST(RayDomain, MeshesBeyondTheCoordinateLimitAreRefused) {
  // The mesh of issue #23 that crashed the BVH: coordinates near +-3e38.
  const std::vector<Triangle> huge = {{{-3e38f, -3e38f, 0}, {3e38f, -3e38f, 0}, {0, 3e38f, 1e38f}},
                                      {{-3e38f, -3e38f, 0}, {3e38f, -3e38f, 0}, {1, 2, 3}}};
  for (const std::string& name : accel_names()) {
    try {
      make_accel(name, huge);
      ADD_FAILURE() << name << " built a mesh beyond the limit";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("beyond the limit"), std::string::npos) << e.what();
    }
  }
  std::vector<Triangle> moved = horse();
  moved[5].v1.y = kNaN;
  for (const char* name : {"bvh", "kd"}) {
    auto accel = make_accel(name, horse());
    EXPECT_THROW(accel->refit(moved), Error) << name;
  }
}

TEST(RayDomain, AMeshAtTheLimitIsTracedExactlyByEveryStructure) {
  // The horse stretched to the coordinate limit, rays from the camera distance that frames it.
  std::vector<Triangle> tris = horse();
  const Aabb box = test::bounds_of(tris);
  const float scale = kMaxCoordinate / max_component(max(abs(box.lo), abs(box.hi)));
  for (Triangle& t : tris) t = {t.v0 * scale, t.v1 * scale, t.v2 * scale};
  const std::vector<Ray> rays = test::hard_rays(tris, 4096, 36);
  const test::Answers brute = test::brute_answers(tris, rays);
  for (const auto& accel : every_structure(tris))
    test::expect_same_answers(brute, test::answers_of(*accel, rays), rays,
                              accel->stats().accel + " at the coordinate limit");
}

}  // namespace
}  // namespace splitray

// Every structure equals brute force on geometry made to break hierarchies (issue #19):
// the ten Sponza triangles that float clipping lost, and 64 generated hostile meshes
// (hostile_geometry.hpp) with 16,384 hard rays each, so that every structure answers 2^20 rays
// with its default settings and 2^18 with each variation (closest hits: same primitive,
// bit-identical t, u, v; any hits).
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <vector>

#include "hierarchy_oracle.hpp"
#include "hostile_geometry.hpp"
#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/render/ray_sets.hpp"

namespace splitray {
namespace {

using test::Answers;

constexpr int kMeshes = 64;
constexpr std::size_t kRaysPerMesh = 16384;

struct Case {
  test::HostileMesh mesh;
  std::vector<Ray> rays;
  Answers brute;
};

const std::vector<Case>& cases() {
  static const std::vector<Case> all = [] {
    std::vector<Case> out(kMeshes);
    for (int i = 0; i < kMeshes; ++i) {
      Case& c = out[static_cast<std::size_t>(i)];
      c.mesh = test::hostile_mesh(0x19, i);
      c.rays = test::hard_rays(c.mesh.tris, kRaysPerMesh, 1000 + static_cast<std::uint64_t>(i));
      c.brute = test::brute_answers(c.mesh.tris, c.rays);
    }
    return out;
  }();
  return all;
}

struct Setting {
  std::string accel;
  BuildConfig config;
  std::string what;
};

Setting setting(const std::string& accel, const std::string& builder, const std::string& what,
                const auto& change) {
  Setting s{accel, {}, accel + " " + builder + " " + what};
  s.config.builder = builder;
  change(s.config);
  return s;
}

// Every `stride`-th mesh: the default settings of every structure see all of them (2^20 rays),
// their variations (cost constants, leaf sizes, depths, bins) a quarter.
void expect_equal_to_brute(const Setting& s, int stride = 1) {
  std::size_t hits = 0;
  for (int i = 0; i < kMeshes; i += stride) {
    const Case& c = cases()[static_cast<std::size_t>(i)];
    const auto structure = make_accel(s.accel, c.mesh.tris, s.config);
    test::expect_same_answers(c.brute, test::answers_of(*structure, c.rays), c.rays,
                              s.what + " on " + c.mesh.name);
    for (const Hit& h : c.brute.hits) hits += h.found() ? 1 : 0;
    if (::testing::Test::HasFailure()) return;  // the first failing mesh says enough
  }
  EXPECT_GT(hits, kMeshes / stride * kRaysPerMesh / 4) << s.what << ": the rays should hit often";
}

const auto kDefault = [](BuildConfig&) {};

TEST(HostileGeometry, MeshesHaveEveryKindOfHostileTriangle) {
  std::size_t thin = 0, planar = 0, degenerate = 0, duplicates = 0, far = 0;
  for (const Case& c : cases()) {
    const auto& tris = c.mesh.tris;
    const Aabb box = test::bounds_of(tris);
    far += std::fabs(box.center().x) > 64 * max_component(box.extent()) ? 1 : 0;
    for (std::size_t i = 0; i < tris.size(); ++i) {
      const Aabb b = tris[i].bounds();
      for (int a = 0; a < 3; ++a) {
        planar += b.lo[a] == b.hi[a] ? 1 : 0;
        thin += b.lo[a] < b.hi[a] &&
                        b.hi[a] <= std::nextafter(std::nextafter(b.lo[a], b.hi[a] + 1), b.hi[a] + 1)
                    ? 1
                    : 0;
      }
      degenerate += tris[i].area() == 0 ? 1 : 0;
      if (i > 0 && std::memcmp(&tris[i], &tris[i - 1], sizeof(Triangle)) == 0) ++duplicates;
    }
  }
  EXPECT_GT(thin, 500u);  // 1-2 ulps thick in some axis
  EXPECT_GT(planar, 500u);
  EXPECT_GT(degenerate, 300u);
  EXPECT_GT(far, 5u);
  (void)duplicates;  // copies of random earlier triangles, rarely adjacent
}

TEST(HostileGeometry, KdTreesOfEveryBuilderEqualBrute) {
  for (const std::string builder : {"sah", "golden", "binned"}) {
    expect_equal_to_brute(setting("kd", builder, "K_T 15", kDefault));
    expect_equal_to_brute(setting("kd", builder, "K_T 1 (deep trees, many perfect splits)",
                                  [](BuildConfig& c) { c.traversal_cost = 1; }),
                          4);
    expect_equal_to_brute(setting("kd", builder, "K_T 60, leaves of 4",
                                  [](BuildConfig& c) {
                                    c.traversal_cost = 60;
                                    c.max_leaf_prims = 4;
                                  }),
                          4);
    expect_equal_to_brute(setting("kd", builder, "depth 6, one thread",
                                  [](BuildConfig& c) {
                                    c.max_depth = 6;
                                    c.threads = 1;
                                  }),
                          4);
  }
  expect_equal_to_brute(setting("kd", "binned", "4 bins", [](BuildConfig& c) { c.bins = 4; }), 4);
}

TEST(HostileGeometry, KdTreesDoNotDependOnTheThreadCount) {
  for (const std::string builder : {"sah", "golden", "binned"}) {
    for (int i = 0; i < kMeshes; i += 4) {
      const Case& c = cases()[static_cast<std::size_t>(i)];
      BuildConfig config;
      config.builder = builder;
      config.threads = 1;
      const auto one = make_accel("kd", c.mesh.tris, config);
      config.threads = 2;
      const auto two = make_accel("kd", c.mesh.tris, config);
      const KdTree& a = dynamic_cast<const KdAccel&>(*one).tree();
      const KdTree& b = dynamic_cast<const KdAccel&>(*two).tree();
      ASSERT_EQ(a.nodes.size(), b.nodes.size()) << builder << " " << c.mesh.name;
      EXPECT_EQ(std::memcmp(a.nodes.data(), b.nodes.data(), a.nodes.size() * sizeof(KdNode)), 0)
          << builder << " " << c.mesh.name;
      EXPECT_EQ(a.prim_ids, b.prim_ids) << builder << " " << c.mesh.name;
    }
  }
}

TEST(HostileGeometry, BihOfEveryBuilderEqualsBrute) {
  expect_equal_to_brute(setting("bih", "global", "", kDefault));
  for (const std::string builder : {"median", "middle", "sah"})
    expect_equal_to_brute(setting("bih", builder, "", kDefault), 4);
}

TEST(HostileGeometry, BvhsEqualBrute) {
  for (const std::string builder : {"binned", "sbvh"}) {
    expect_equal_to_brute(setting("bvh", builder, "", kDefault));
    expect_equal_to_brute(setting("bvh", builder, "leaves of 1, one thread",
                                  [](BuildConfig& c) {
                                    c.max_leaf_prims = 1;
                                    c.threads = 1;
                                  }),
                          4);
  }
}

// The shipped model's top, down to its full depth (no cell is left to the expansion builder
// for being small), expanded by every builder: perfect splits at the top's planes too.
TEST(HostileGeometry, NeuralExpansionsEqualBrute) {
  const auto deepest = [](BuildConfig& c) { c.neural.top_min = 0; };
  for (const std::string expand : {"sah", "golden", "binned"})
    expect_equal_to_brute(setting("kd", "neural", "+" + expand, [&](BuildConfig& c) {
      deepest(c);
      c.neural.expand = expand;
    }));
  for (const std::string expand : {"binned", "sbvh"})
    expect_equal_to_brute(setting("bvh", "neural", "+" + expand, [&](BuildConfig& c) {
      deepest(c);
      c.neural.expand = expand;
    }));
}

// The distance from p to the triangle (Ericson, Real-Time Collision Detection, 5.1.5), in
// double.
double distance_to_triangle(const Triangle& tri, const double p[3]) {
  double a[3], b[3], c[3];
  for (int j = 0; j < 3; ++j) a[j] = tri.v0[j], b[j] = tri.v1[j], c[j] = tri.v2[j];
  const auto sub = [](const double* x, const double* y, double* out) {
    for (int j = 0; j < 3; ++j) out[j] = x[j] - y[j];
  };
  const auto dot = [](const double* x, const double* y) {
    return x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
  };
  const auto dist = [&](const double* q) {
    double d[3];
    sub(p, q, d);
    return std::sqrt(dot(d, d));
  };
  // The closest point on the segment x-y.
  const auto segment = [&](const double* x, const double* y) {
    double d[3], e[3], q[3];
    sub(y, x, d);
    sub(p, x, e);
    const double dd = dot(d, d);
    const double t = dd > 0 ? std::clamp(dot(e, d) / dd, 0.0, 1.0) : 0.0;
    for (int j = 0; j < 3; ++j) q[j] = x[j] + d[j] * t;
    return dist(q);
  };
  double ab[3], ac[3], ap[3], n[3];
  sub(b, a, ab);
  sub(c, a, ac);
  sub(p, a, ap);
  n[0] = ab[1] * ac[2] - ab[2] * ac[1];
  n[1] = ab[2] * ac[0] - ab[0] * ac[2];
  n[2] = ab[0] * ac[1] - ab[1] * ac[0];
  const double nn = dot(n, n);
  double best = std::min({segment(a, b), segment(b, c), segment(c, a)});
  if (nn > 0) {  // the projection onto the plane, when it falls inside the triangle
    const double s = dot(ap, n) / nn;
    double q[3], w[3];
    for (int j = 0; j < 3; ++j) q[j] = p[j] - n[j] * s;
    const auto side = [&](const double* x, const double* y) {
      double xy[3], xq[3];
      sub(y, x, xy);
      sub(q, x, xq);
      w[0] = xy[1] * xq[2] - xy[2] * xq[1];
      w[1] = xy[2] * xq[0] - xy[0] * xq[2];
      w[2] = xy[0] * xq[1] - xy[1] * xq[0];
      return dot(w, n);
    };
    if (side(a, b) >= 0 && side(b, c) >= 0 && side(c, a) >= 0) best = std::min(best, dist(q));
  }
  return best;
}

// What every hierarchy relies on: a hit the triangle test reports lies on (within rounding of)
// its triangle, so the cells that hold the triangle are where the ray meets it. On degenerate
// and sliver triangles the float barycentrics are rounding noise and once put hits far off the
// triangle (a collinear triangle hit 0.4 units beside itself in a scene of 1,000): the test
// decides those in double and misses triangles that are degenerate there.
TEST(HostileGeometry, TriangleTestHitsLieOnTheirTriangle) {
  std::size_t hits = 0;
  for (int i = 0; i < kMeshes; i += 2) {
    const Case& c = cases()[static_cast<std::size_t>(i)];
    const Aabb box = test::bounds_of(c.mesh.tris);
    const float magnitude = std::max(max_component(abs(box.lo)), max_component(abs(box.hi)));
    for (std::size_t r = 0; r < c.rays.size(); r += 4) {
      const Ray& ray = c.rays[r];
      const WatertightRay w(ray);
      for (const Triangle& tri : c.mesh.tris) {
        float t, u, v;
        if (!intersect_triangle(w, tri, ray.tmin, ray.tmax, t, u, v)) continue;
        ++hits;
        const double p[3] = {ray.org.x + double(ray.dir.x) * t, ray.org.y + double(ray.dir.y) * t,
                             ray.org.z + double(ray.dir.z) * t};
        const double reach = std::max({std::fabs(p[0]), std::fabs(p[1]), std::fabs(p[2]),
                                       double(max_component(abs(ray.org)))});
        // A quarter of the hierarchies' margins (2^-18 of the scene's and the ray's scale).
        ASSERT_LE(distance_to_triangle(tri, p), 0x1p-20 * (reach + magnitude))
            << c.mesh.name << " ray " << r << " t " << t;
      }
    }
  }
  EXPECT_GT(hits, 50000u);
}

// The ten Sponza triangles of issue #19 (data/regress_kd_clip/SOURCE.md): face 2 is two ulps
// thick in y; float clipping made its box flat and the cell below a split lost it.
const std::vector<Triangle>& atrium() {
  static const std::vector<Triangle> tris =
      test::load_triangles(test::vendored_file("regress_kd_clip/kd_clip_10tris.obj"));
  return tris;
}

const std::vector<Setting>& kd_settings() {
  static const std::vector<Setting> all = [] {
    std::vector<Setting> out;
    for (const std::string builder : {"sah", "golden", "binned"})
      out.push_back(setting("kd", builder, "", kDefault));
    for (const std::string expand : {"sah", "golden", "binned"})
      out.push_back(setting("kd", "neural", "+" + expand, [&](BuildConfig& c) {
        c.neural.top_min = 0;
        c.neural.expand = expand;
      }));
    return out;
  }();
  return all;
}

TEST(KdClipRegression, TheAtriumRayHitsTheThinFace) {
  ASSERT_EQ(atrium().size(), 10u);
  const Ray ray{{-0x1.57a3ecp+3f, 0x1.3c155cp+2f, -0x1.b95bf4p+1f},
                {0x1.002c84p-2f, -0x1.d4c32p-2f, 0x1.b4cf7p-1f}};
  const Hit brute = make_accel("brute", atrium())->intersect(ray);
  ASSERT_EQ(brute.prim, 2u);
  ASSERT_EQ(std::bit_cast<std::uint32_t>(brute.t), std::bit_cast<std::uint32_t>(0x1.0258acp-2f));
  for (const Setting& s : kd_settings()) {
    const Hit hit = make_accel(s.accel, atrium(), s.config)->intersect(ray);
    EXPECT_EQ(hit.prim, 2u) << s.what;
    EXPECT_EQ(std::bit_cast<std::uint32_t>(hit.t), std::bit_cast<std::uint32_t>(brute.t)) << s.what;
  }
}

TEST(KdClipRegression, AMillionRandomRaysEqualBrute) {
  // `splitray trace kd_clip_10tris.obj --kind random --rays 1000000 --seed 1`'s rays.
  const std::vector<Ray> rays = make_rays(atrium(), RayKind::random, 1, 1'000'000);
  const Answers brute = test::brute_answers(atrium(), rays);
  for (const Setting& s : kd_settings())
    test::expect_same_answers(brute,
                              test::answers_of(*make_accel(s.accel, atrium(), s.config), rays),
                              rays, s.what + " on the atrium's ten triangles");
}

}  // namespace
}  // namespace splitray

#pragma once
// Shared by the hierarchy tests (BIH, BVH): real meshes, hard ray sets and a comparison with
// `brute` that demands the same primitive and bit-identical t, u, v for every ray.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/accel/brute/brute.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/random.hpp"
#include "splitray/io/mesh_io.hpp"
#include "test_data.hpp"

namespace splitray::test {

inline std::vector<Triangle> load_triangles(const std::string& path) {
  return load_mesh(path).triangles();
}

inline Aabb bounds_of(const std::vector<Triangle>& tris) {
  Aabb b;
  for (const Triangle& t : tris) b.extend(t.bounds());
  return b;
}

// Rays that stress a hierarchy: from inside the bounds in every direction; from outside
// toward points on triangles, their vertices and edges (shared by neighbours); parallel to
// the axes, also lying in planes through vertices; short segments with tmin > 0.
inline std::vector<Ray> hard_rays(const std::vector<Triangle>& tris, std::size_t count,
                                  std::uint64_t seed) {
  Pcg32 rng(seed);
  const Aabb box = bounds_of(tris);
  const Vec3 center = box.center(), extent = box.extent();
  const float radius = length(extent);
  const auto uniform_in_box = [&] {
    return Vec3{box.lo.x + extent.x * rng.next_float(), box.lo.y + extent.y * rng.next_float(),
                box.lo.z + extent.z * rng.next_float()};
  };
  const auto outside = [&] {
    return center + uniform_sphere(rng.next_float(), rng.next_float()) *
                        (radius * (0.6f + 1.5f * rng.next_float()));
  };
  const auto random_tri = [&]() -> const Triangle& { return tris[rng.next_u32() % tris.size()]; };
  std::vector<Ray> rays;
  rays.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    Ray ray;
    switch (i % 8) {
      case 0:
      case 1:  // inside, any direction
        ray.org = uniform_in_box();
        ray.dir = uniform_sphere(rng.next_float(), rng.next_float());
        break;
      case 2: {  // outside toward a point on a triangle
        const Triangle& t = random_tri();
        float a = rng.next_float(), b = rng.next_float();
        if (a + b > 1) a = 1 - a, b = 1 - b;
        ray.org = outside();
        ray.dir = t.v0 + (t.v1 - t.v0) * a + (t.v2 - t.v0) * b - ray.org;
        break;
      }
      case 3:    // toward a vertex, shared by several triangles
      case 4: {  // toward a point on an edge
        const Triangle& t = random_tri();
        const int k = static_cast<int>(rng.next_u32() % 3);
        Vec3 target = t.vertex(k);
        if (i % 8 == 4) target = target + (t.vertex((k + 1) % 3) - target) * rng.next_float();
        ray.org = (rng.next_u32() & 1) ? outside() : uniform_in_box();
        ray.dir = target - ray.org;
        break;
      }
      case 5: {  // along an axis (zero direction components)
        ray.org = uniform_in_box();
        const int axis = static_cast<int>(rng.next_u32() % 3);
        ray.dir = Vec3{0.0f};
        ray.dir[axis] = (rng.next_u32() & 1) ? 1.0f : -1.0f;
        break;
      }
      case 6: {  // in a plane through a vertex, parallel to that plane's axis
        const Triangle& t = random_tri();
        const int axis = static_cast<int>(rng.next_u32() % 3);
        ray.org = uniform_in_box();
        ray.org[axis] = t.vertex(static_cast<int>(rng.next_u32() % 3))[axis];
        ray.dir = uniform_sphere(rng.next_float(), rng.next_float());
        ray.dir[axis] = (rng.next_u32() & 1) ? 0.0f : -0.0f;
        if (rng.next_u32() & 1) ray.org = ray.org - ray.dir * radius;  // start outside
        break;
      }
      default: {  // a segment toward a surface point that may stop short of it
        const Triangle& t = random_tri();
        ray.org = (rng.next_u32() & 1) ? outside() : uniform_in_box();
        ray.dir = (t.v0 + t.v1 + t.v2) * (1.0f / 3) - ray.org;
        ray.tmin = 0.05f * rng.next_float();
        ray.tmax = 0.5f + rng.next_float();
        break;
      }
    }
    if (!(length(ray.dir) > 0)) ray.dir = {1, 0, 0};
    rays.push_back(ray);
  }
  return rays;
}

// Rays from off the surface aimed at the centroid of every `stride`-th triangle: every
// triangle must stay reachable.
inline std::vector<Ray> centroid_rays(const std::vector<Triangle>& tris, std::uint64_t seed,
                                      std::size_t stride = 1) {
  Pcg32 rng(seed);
  const Aabb box = bounds_of(tris);
  const float radius = length(box.extent());
  std::vector<Ray> rays;
  rays.reserve(tris.size() / stride + 1);
  for (std::size_t i = 0; i < tris.size(); i += stride) {
    const Triangle& t = tris[i];
    const Vec3 c = (t.v0 + t.v1 + t.v2) * (1.0f / 3);
    Vec3 n = normalize(t.geometric_normal());
    if (!(length(n) > 0)) n = uniform_sphere(rng.next_float(), rng.next_float());
    const Vec3 org = c + n * (radius * (0.01f + rng.next_float()));
    rays.push_back({org, c - org});
  }
  return rays;
}

struct Answers {
  std::vector<Hit> hits;
  std::vector<std::uint8_t> occluded;
};

// Brute's answers. Its any-hit answer is derived from its closest hit: both run the same
// triangle test over the same [tmin, tmax], so a ray is occluded exactly when a closest hit
// exists (this halves the oracle's cost).
inline Answers brute_answers(const std::vector<Triangle>& tris, const std::vector<Ray>& rays) {
  Answers a;
  a.hits.resize(rays.size());
  make_brute(tris, {})->intersect(rays, a.hits);
  a.occluded.resize(rays.size());
  for (std::size_t i = 0; i < rays.size(); ++i) a.occluded[i] = a.hits[i].found() ? 1 : 0;
  return a;
}

inline Answers answers_of(const Accel& accel, const std::vector<Ray>& rays) {
  Answers a;
  a.hits.resize(rays.size());
  a.occluded.resize(rays.size());
  accel.intersect(rays, a.hits);
  accel.occluded(rays, a.occluded);
  return a;
}

// The same through single-ray functions (for structures outside the Accel interface).
template <class Structure>
Answers answers_of_structure(const Structure& s, const std::vector<Ray>& rays) {
  Answers a;
  a.hits.resize(rays.size());
  a.occluded.resize(rays.size());
  parallel_chunks(rays.size(), 256, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      a.hits[i] = s.intersect(rays[i]);
      a.occluded[i] = s.occluded(rays[i]) ? 1 : 0;
    }
  });
  return a;
}

inline bool same_hit(const Hit& a, const Hit& b) {
  return a.prim == b.prim &&
         std::bit_cast<std::uint32_t>(a.t) == std::bit_cast<std::uint32_t>(b.t) &&
         std::bit_cast<std::uint32_t>(a.u) == std::bit_cast<std::uint32_t>(b.u) &&
         std::bit_cast<std::uint32_t>(a.v) == std::bit_cast<std::uint32_t>(b.v);
}

// Every closest hit identical (prim, bit-identical t, u, v) and every any-hit answer equal.
inline void expect_same_answers(const Answers& expected, const Answers& got,
                                const std::vector<Ray>& rays, const std::string& what) {
  ASSERT_EQ(expected.hits.size(), got.hits.size());
  std::size_t wrong_hits = 0, wrong_occluded = 0, found = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    found += expected.hits[i].found() ? 1 : 0;
    if (!same_hit(expected.hits[i], got.hits[i])) {
      if (wrong_hits++ < 5)
        ADD_FAILURE() << what << ": ray " << i << " expected prim " << expected.hits[i].prim
                      << " t " << expected.hits[i].t << ", got prim " << got.hits[i].prim << " t "
                      << got.hits[i].t;
    }
    if (expected.occluded[i] != got.occluded[i]) {
      if (wrong_occluded++ < 5)
        ADD_FAILURE() << what << ": ray " << i << " occluded expected " << int(expected.occluded[i])
                      << ", got " << int(got.occluded[i]);
    }
  }
  EXPECT_EQ(wrong_hits, 0u) << what;
  EXPECT_EQ(wrong_occluded, 0u) << what;
  EXPECT_GT(found, rays.size() / 10) << what << ": the ray set should hit the mesh often";
}

// A mesh with its hard rays and brute's answers, computed once per test program.
struct Reference {
  std::vector<Triangle> tris;
  std::vector<Ray> rays;
  Answers brute;
};

inline const Reference& reference(const std::string& path, std::size_t ray_count = 24000) {
  static std::map<std::string, std::unique_ptr<Reference>> cache;
  auto& slot = cache[path];
  if (!slot) {
    slot = std::make_unique<Reference>();
    slot->tris = load_triangles(path);
    slot->rays = hard_rays(slot->tris, ray_count, 0x5eed);
    slot->brute = brute_answers(slot->tris, slot->rays);
  }
  return *slot;
}

}  // namespace splitray::test

// The parts every traversal shares: the culled stack pop (accel/traversal_stack.hpp) and the
// conservative ray set-up (accel/robust_ray.hpp), whose two clip styles must each contain the
// exact (long double) interval of the ray in a box.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "splitray/accel/robust_ray.hpp"
#include "splitray/accel/traversal_stack.hpp"
#include "splitray/core/random.hpp"

namespace splitray {
namespace {

struct Entry {
  int id;
  float t0;
};

TEST(TraversalStack, PopsTheNearestNotBehindTheHit) {
  TraversalStack<Entry, 8> stack;
  EXPECT_TRUE(stack.empty());
  EXPECT_EQ(stack.pop_not_behind(1.0f), nullptr);
  // Pushed farther first: 4 is the farthest, 1 the nearest.
  stack.push({4, 9.0f});
  stack.push({3, 5.0f});
  stack.push({2, std::nanf("")});
  stack.push({1, 2.0f});
  const Entry* e = stack.pop_not_behind(kInfinity);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->id, 1);
  // A hit at t = 5: the NaN entry is dropped, the entry at exactly 5 is kept (a smaller id may
  // lie there at the same t).
  e = stack.pop_not_behind(5.0f);
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->id, 3);
  // A hit at 8.5: the entry at 9 is behind it and dropped; the stack runs out.
  EXPECT_EQ(stack.pop_not_behind(8.5f), nullptr);
  EXPECT_TRUE(stack.empty());
}

TEST(TraversalStack, PopUntilStopsAtTheFirstKeptEntry) {
  TraversalStack<Entry, 4> stack;
  for (int i = 0; i < 4; ++i) stack.push({i, static_cast<float>(i)});
  int seen = 0;
  const Entry* e = stack.pop_until([&](const Entry& x) {
    ++seen;
    return x.id == 1;
  });
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->id, 1);
  EXPECT_EQ(seen, 3);  // 3, 2, then 1
  e = stack.pop_until([](const Entry&) { return true; });
  ASSERT_NE(e, nullptr);
  EXPECT_EQ(e->id, 0);
  EXPECT_TRUE(stack.empty());
}

TEST(RobustRay, ZeroDirectionsGiveAFiniteSignedInverse) {
  const Aabb scene{{-1, -1, -1}, {1, 1, 1}};
  Ray ray;
  ray.org = {0.5f, 0.25f, 0};
  ray.dir = {0.0f, -0.0f, 1.0f};
  const RobustRay r(ray, scene, coordinate_magnitude(scene));
  EXPECT_TRUE(std::isfinite(r.inv.x) && r.inv.x > 0);
  EXPECT_TRUE(std::isfinite(r.inv.y) && r.inv.y < 0);
  EXPECT_EQ(r.negative[0], 0);
  EXPECT_EQ(r.negative[1], 1);
  EXPECT_EQ(r.negative[2], 0);
  EXPECT_GT(r.delta, 0.0f);
  // The origin lies inside the slabs of x and y: both styles keep the ray in them.
  EXPECT_LE(r.entry(0, -1, 1), 0.0f);
  EXPECT_GT(r.exit(0, -1, 1), 1e6f);
  const RobustRay::Splits s = r.splits(scene, 0, kInfinity);
  EXPECT_LE(s.t0, 0.0f);
  EXPECT_GE(s.t1, 1.0f);
}

using Real = long double;

// Both clip styles contain the exact interval of the ray in random boxes of a scene, for
// random rays (origins inside and outside the scene, far away, direction components zero or
// tiny) up to the farthest t at which the ray can still meet the scene.
TEST(RobustRay, BothClipStylesContainTheExactInterval) {
  Pcg32 rng(2025);
  const auto uniform = [&](float lo, float hi) { return lo + (hi - lo) * rng.next_float(); };
  int checked = 0;
  for (int round = 0; round < 200000; ++round) {
    const float scale = std::ldexp(1.0f, static_cast<int>(rng.next_u32() % 40) - 12);
    const Vec3 offset = round % 3 == 0
                            ? Vec3{uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)} * (scale * 4096)
                            : Vec3{};
    const Aabb scene{offset - Vec3{scale, scale, scale}, offset + Vec3{scale, scale, scale}};
    Aabb box;
    for (int k = 0; k < 2; ++k)
      box.extend(offset + Vec3{uniform(-1, 1), uniform(-1, 1), uniform(-1, 1)} * scale);
    Ray ray;
    ray.org = offset + Vec3{uniform(-3, 3), uniform(-3, 3), uniform(-3, 3)} * scale;
    const Vec3 aim{uniform(box.lo.x, box.hi.x), uniform(box.lo.y, box.hi.y),
                   uniform(box.lo.z, box.hi.z)};
    ray.dir = round % 4 == 0 ? uniform_sphere(rng.next_float(), rng.next_float())
                             : (aim - ray.org) * (1 / scale);
    if (round % 5 == 1) ray.dir[round % 3] = round % 2 ? 0.0f : -0.0f;
    if (round % 5 == 2) ray.dir[round % 3] *= 0x1p-45f;
    if (round % 5 == 3) ray.org[round % 3] = box.lo[round % 3];  // in a plane of the box
    const RobustRay r(ray, scene, coordinate_magnitude(scene));
    const RobustRay::Splits s = r.splits(box, 0, kInfinity);
    // Exact: the ray's interval in the box, within [0, the farthest t reaching the scene].
    Real distance = 0, length = 0;
    for (int a = 0; a < 3; ++a) {
      const Real far = std::max(std::fabs(Real{ray.org[a]} - scene.lo[a]),
                                std::fabs(Real{ray.org[a]} - scene.hi[a]));
      distance += far * far;
      length += Real{ray.dir[a]} * ray.dir[a];
    }
    const Real t_far = std::sqrt(distance / length);
    Real te = 0, tx = t_far;
    for (int a = 0; a < 3; ++a) {
      const Real o = ray.org[a], d = ray.dir[a];
      if (d == 0) {
        if (o < box.lo[a] || o > box.hi[a]) te = tx + 1;  // never inside
        continue;
      }
      const Real ta = (box.lo[a] - o) / d, tb = (box.hi[a] - o) / d;
      te = std::max(te, std::min(ta, tb));
      tx = std::min(tx, std::max(ta, tb));
    }
    if (!(te <= tx)) continue;
    ++checked;
    // Box style (BVH, BIH).
    float t0 = 0, t1 = kInfinity;
    for (int a = 0; a < 3; ++a) {
      t0 = max_keep(t0, r.entry(a, box.lo[a], box.hi[a]));
      t1 = min_keep(t1, r.exit(a, box.lo[a], box.hi[a]));
    }
    ASSERT_TRUE(t0 <= te && tx <= t1) << "box style, round " << round;
    // Split style (kd).
    ASSERT_TRUE(s.t0 <= te && tx <= s.t1) << "split style, round " << round;
  }
  EXPECT_GT(checked, 50000);
}

}  // namespace
}  // namespace splitray

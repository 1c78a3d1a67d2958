// SIMD code equals the scalar code it repeats, bit for bit: the wrappers of core/simd.hpp lane
// by lane against the scalar operations (NaN, signed zeros, infinities and denormals included),
// the 8-wide watertight test (core/triangle_simd.hpp) against the scalar test, its constants
// made for eight rays at once against one ray's, and the AVX2 7-plane clip of the wide kd walk
// (accel/kd/kd_wide_clip.hpp) against its portable twin.
// Builds without the instructions skip the comparisons they cannot make.
#include "splitray/core/simd.hpp"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "splitray/accel/kd/kd_wide_clip.hpp"
#include "splitray/accel/robust_ray.hpp"
#include "splitray/core/random.hpp"
#include "splitray/core/triangle.hpp"
#include "splitray/core/triangle_simd.hpp"

namespace splitray {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Values that tell IEEE semantics apart, then random ones of every magnitude and sign.
std::vector<float> test_values(std::size_t n) {
  std::vector<float> v = {
      0.0f,  -0.0f,         1.0f,      -1.0f,      kInf,
      -kInf, std::nanf(""), 0x1p-149f, -0x1p-140f, 0x1p-126f,
      3.0f,  -2.5f,         0x1p100f,  7.0f,       std::numeric_limits<float>::max(),
      1.0f};
  Pcg32 rng(7);
  while (v.size() < n) {
    const float mantissa = 1.0f + rng.next_float();
    const int exponent = static_cast<int>(rng.next_u32() % 80) - 40;
    v.push_back((rng.next_u32() & 1 ? -1.0f : 1.0f) * std::ldexp(mantissa, exponent));
  }
  return v;
}

bool same_bits(float a, float b) {
  return std::bit_cast<std::uint32_t>(a) == std::bit_cast<std::uint32_t>(b);
}

// Every wrapper of F against the scalar operation it stands for, over all pairs of lanes
// taken from `values` (a rotated copy as the second operand).
template <class F>
void check_wrappers(const std::vector<float>& values) {
  constexpr int n = F::kLanes;
  for (std::size_t base = 0; base + n <= values.size(); base += n) {
    for (std::size_t shift = 0; shift < values.size(); shift += 3) {
      alignas(64) float a[n], b[n], out[n];
      for (int l = 0; l < n; ++l) {
        a[l] = values[base + l];
        b[l] = values[(base + l + shift) % values.size()];
      }
      const F x = F::load(a), y = F::loadu(b);
      const auto check = [&](const char* what, F result, auto scalar) {
        result.store(out);
        for (int l = 0; l < n; ++l)
          ASSERT_TRUE(same_bits(out[l], scalar(a[l], b[l])))
              << what << "(" << a[l] << ", " << b[l] << ") lane " << l << ": " << out[l];
      };
      check("+", x + y, [](float p, float q) { return p + q; });
      check("-", x - y, [](float p, float q) { return p - q; });
      check("*", x * y, [](float p, float q) { return p * q; });
      check("/", x / y, [](float p, float q) { return p / q; });
      check("min", min(x, y), [](float p, float q) { return p < q ? p : q; });
      check("max", max(x, y), [](float p, float q) { return p > q ? p : q; });
      check("abs", abs(x), [](float p, float) { return std::fabs(p); });
      check("sign", with_sign(abs(x), y), [](float p, float q) { return std::copysign(p, q); });
      check("select", select(x < y, x, y), [](float p, float q) { return p < q ? p : q; });
      check("broadcast", F::broadcast(b[0]), [&](float, float) { return b[0]; });
      const auto check_mask = [&](const char* what, auto mask, auto scalar) {
        unsigned expected = 0;
        for (int l = 0; l < n; ++l) expected |= (scalar(a[l], b[l]) ? 1u : 0u) << l;
        ASSERT_EQ(mask.bits(), expected) << what;
      };
      check_mask("<", x < y, [](float p, float q) { return p < q; });
      check_mask("<=", x <= y, [](float p, float q) { return p <= q; });
      check_mask(">", x > y, [](float p, float q) { return p > q; });
      check_mask(">=", x >= y, [](float p, float q) { return p >= q; });
      check_mask("==", x == y, [](float p, float q) { return p == q; });
      check_mask("!=", x != y, [](float p, float q) { return p != q; });
      check_mask("|", (x < y) | (x == F::zero()), [](float p, float q) { return p < q || p == 0; });
      check_mask("&", (x < y) & (y > F::zero()), [](float p, float q) { return p < q && q > 0; });
      x.storeu(out);
      for (int l = 0; l < n; ++l) ASSERT_TRUE(same_bits(out[l], a[l]));
    }
  }
}

TEST(Simd, Float8EqualsScalarLaneByLane) {
#if defined(__AVX__)
  check_wrappers<simd::Float8>(test_values(200));
#else
  GTEST_SKIP() << "built without AVX";
#endif
}

TEST(Simd, Float16EqualsScalarLaneByLane) {
#if defined(__AVX512F__)
  check_wrappers<simd::Float16>(test_values(208));
#else
  GTEST_SKIP() << "built without AVX-512";
#endif
}

TEST(Simd, MinOfTheMaskedLanesEqualsTheScalarMinimum) {
#if defined(__AVX512F__)
  Pcg32 rng(7);
  for (int round = 0; round < 2000; ++round) {
    alignas(64) float x[16];
    for (float& v : x) v = 200 * rng.next_float() - 100;
    if (round % 5 == 0) x[round % 16] = -std::numeric_limits<float>::infinity();
    const unsigned mask = round == 1 ? 0u : rng.next_u32() & 0xffffu;
    float expected = std::numeric_limits<float>::infinity();  // empty mask: +inf
    for (int i = 0; i < 16; ++i)
      if (mask & (1u << i)) expected = std::min(expected, x[i]);
    ASSERT_EQ(simd::min_of(simd::Float16::load(x), simd::Mask16{static_cast<__mmask16>(mask)}),
              expected)
        << "round " << round;
  }
#else
  GTEST_SKIP() << "built without AVX-512";
#endif
}

TEST(Simd, PermuteTakesTheIndexedLanes) {
#if defined(__AVX2__)
  alignas(32) const float table[8] = {10, 11, 12, 13, 14, 15, 16, 17};
  alignas(32) float out[8];
  simd::permute(simd::Float8::load(table), _mm256_setr_epi32(7, 0, 0, 3, 2, 6, 5, 1)).store(out);
  const float expected[8] = {17, 10, 10, 13, 12, 16, 15, 11};
  for (int l = 0; l < 8; ++l) EXPECT_EQ(out[l], expected[l]);
#else
  GTEST_SKIP() << "built without AVX2";
#endif
}

// Triangles and rays of the kinds that decide the watertight test's branches: random ones,
// rays through vertices and edge midpoints (edge functions exactly zero), slivers and
// degenerate triangles (decided in double), rays far from the triangles.
TEST(Simd, Watertight8EqualsTheScalarTest) {
#if defined(__AVX__)
  Pcg32 rng(25);
  const auto point = [&](float scale) {
    return Vec3{rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float() - 0.5f} * scale;
  };
  int hits = 0, handed_back = 0;
  for (int round = 0; round < 4000; ++round) {
    Triangle tris[8];
    for (int i = 0; i < 8; ++i) {
      tris[i] = {point(2), point(2), point(2)};
      if (i == 5) tris[i].v2 = tris[i].v0 + (tris[i].v1 - tris[i].v0) * 0.5f;  // degenerate
      if (i == 6) tris[i].v2 = tris[i].v1 + Vec3{0x1p-20f, 0, 0};              // sliver
    }
    const Triangle& target = tris[round % 8];
    Vec3 aim = target.v0 * 0.3f + target.v1 * 0.3f + target.v2 * 0.4f;
    if (round % 5 == 1) aim = target.v1;                       // a vertex
    if (round % 5 == 2) aim = (target.v0 + target.v2) * 0.5f;  // an edge
    if (round % 5 == 3) aim = point(4);                        // anywhere
    const Vec3 org = point(8) + Vec3{0, 0, 5};
    Ray ray;
    ray.org = org;
    ray.dir = aim - org;
    ray.tmin = 0;
    ray.tmax = round % 7 == 0 ? 0.9f : kInf;
    const WatertightRay w(ray);
    alignas(32) float rows[9][8];
    for (int i = 0; i < 8; ++i)
      for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c) rows[3 * k + c][i] = tris[i].vertex(k)[c];
    const unsigned valid = round % 11 == 0 ? 0x5au : 0xffu;
    alignas(32) float t[8], u[8], v[8];
    unsigned scalar = 0;
    const Watertight8 test(w);
    const unsigned found =
        test.test([&](int k, int c) { return simd::Float8::load(rows[3 * k + c]); }, valid,
                  ray.tmin, ray.tmax, t, u, v, scalar);
    ASSERT_EQ(found & scalar, 0u);
    ASSERT_EQ((found | scalar) & ~valid, 0u);
    for (int i = 0; i < 8; ++i) {
      if (!(valid >> i & 1) || (scalar >> i & 1)) {
        handed_back += (scalar >> i) & 1;
        continue;
      }
      float st, su, sv;
      const bool scalar_hit = intersect_triangle(w, tris[i], ray.tmin, ray.tmax, st, su, sv);
      ASSERT_EQ(scalar_hit, (found >> i & 1) != 0) << "round " << round << " lane " << i;
      if (!scalar_hit) continue;
      ++hits;
      EXPECT_TRUE(same_bits(t[i], st) && same_bits(u[i], su) && same_bits(v[i], sv))
          << "round " << round << " lane " << i;
    }
  }
  EXPECT_GT(hits, 1000);
  EXPECT_GT(handed_back, 100);  // the edge and ill-conditioned lanes were exercised
#else
  GTEST_SKIP() << "built without AVX";
#endif
}

// WatertightLanes (the BVH's groups' constants of eight rays) against WatertightRay ray by ray:
// directions with ties between the largest components, signed zeros, tiny and huge components.
TEST(Simd, WatertightLanesEqualWatertightRay) {
#if defined(__AVX__)
  Pcg32 rng(31);
  const float special[] = {0.0f, -0.0f, 1.0f, -1.0f, 0x1p-30f, -0x1p20f, 0.5f, -0.5f};
  for (int round = 0; round < 2000; ++round) {
    alignas(32) float d[3][8];
    Vec3 org[8];
    for (int l = 0; l < 8; ++l) {
      for (int a = 0; a < 3; ++a) {
        d[a][l] = round % 3 == 0 ? special[rng.next_u32() % 8] : 2.0f * rng.next_float() - 1.0f;
        org[l][a] = rng.next_float();
      }
      if (round % 5 == 1) d[1][l] = d[0][l];                                   // |x| = |y|
      if (round % 5 == 2) d[2][l] = -d[1][l];                                  // |y| = |z|
      if (d[0][l] == 0 && d[1][l] == 0 && d[2][l] == 0) d[l % 3][l] = -0.25f;  // a direction
    }
    const simd::Float8 dir[3] = {simd::Float8::load(d[0]), simd::Float8::load(d[1]),
                                 simd::Float8::load(d[2])};
    const WatertightLanes<simd::Float8> lanes(dir);
    for (int l = 0; l < 8; ++l) {
      Ray ray;
      ray.org = org[l];
      ray.dir = {d[0][l], d[1][l], d[2][l]};
      const WatertightRay expected(ray), got = lanes.ray(l, org[l]);
      ASSERT_EQ(got.kx, expected.kx) << "round " << round << " lane " << l;
      ASSERT_EQ(got.ky, expected.ky) << "round " << round << " lane " << l;
      ASSERT_EQ(got.kz, expected.kz) << "round " << round << " lane " << l;
      EXPECT_TRUE(same_bits(got.sx, expected.sx) && same_bits(got.sy, expected.sy) &&
                  same_bits(got.sz, expected.sz))
          << "round " << round << " lane " << l;
    }
  }
#else
  GTEST_SKIP() << "built without AVX";
#endif
}

// A wide node with random axes, splits (some virtual: +inf), and occupied cells.
KdWideNode random_node(Pcg32& rng) {
  KdWideNode node{};
  node.meta = KdWideNode::kMetaBase;
  for (int p = 0; p < 7; ++p) {
    node.meta |= (rng.next_u32() % 3) << (2 * p);
    node.split[p] = rng.next_u32() % 9 == 0 ? kInf : 4 * rng.next_float() - 2;
  }
  node.meta |= (rng.next_u32() & 0xffu) << KdWideNode::kOccupiedShift;
  for (int c = 0; c < 8; ++c) node.child[c] = static_cast<std::uint32_t>(c);
  return node;
}

TEST(Simd, WideKdClipEqualsItsPortableTwin) {
#if defined(__AVX2__)
  Pcg32 rng(3);
  const Aabb root{{-2, -2, -2}, {2, 2, 2}};
  int entered = 0;
  for (int round = 0; round < 20000; ++round) {
    Ray ray;
    ray.org = {3 * rng.next_float() - 1.5f, 3 * rng.next_float() - 1.5f,
               3 * rng.next_float() - 1.5f};
    ray.dir = uniform_sphere(rng.next_float(), rng.next_float());
    if (round % 4 == 1) ray.dir[round % 3] = round % 8 == 1 ? -0.0f : 0.0f;  // parallel to planes
    ray.tmin = 0;
    ray.tmax = kInf;
    const RobustRay r(ray, root, coordinate_magnitude(root));
    const RobustRay::Splits s = r.splits(root, ray.tmin, ray.tmax);
    const float org[3] = {r.org.x, r.org.y, r.org.z}, inv[3] = {r.inv.x, r.inv.y, r.inv.z};
    const KdWideNode node = random_node(rng);
    const KdCellClip portable = clip_cells(node, org, inv, s.pad, s.t0, s.t1);
    const KdCellClip wide =
        clip_cells(node, _mm256_setr_ps(org[0], org[1], org[2], 0, 0, 0, 0, 0),
                   _mm256_setr_ps(inv[0], inv[1], inv[2], 1, 1, 1, 1, 1),
                   _mm256_setr_ps(s.pad[0], s.pad[1], s.pad[2], 0, 0, 0, 0, 0), s.t0, s.t1);
    ASSERT_EQ(wide.enter, portable.enter) << "round " << round;
    for (int level = 0; level < 3; ++level) ASSERT_EQ(wide.second[level], portable.second[level]);
    for (int c = 0; c < 8; ++c)
      ASSERT_TRUE(same_bits(wide.t0[c], portable.t0[c]) && same_bits(wide.t1[c], portable.t1[c]))
          << "round " << round << " cell " << c;
    entered += std::popcount(wide.enter);
  }
  EXPECT_GT(entered, 10000);
#else
  GTEST_SKIP() << "built without AVX2";
#endif
}

}  // namespace
}  // namespace splitray

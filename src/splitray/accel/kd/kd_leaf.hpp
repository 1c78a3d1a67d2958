#pragma once
// The leaves' triangles of a kd-tree in a SIMD-friendly layout, and the leaf test.
//
// Every leaf's n triangles are stored as 9 rows of n floats (v0.x, v0.y, v0.z, v1.x, ..., v2.z)
// at 9 * (the leaf's first index in KdTree::prim_ids), so a leaf needs no extra offset and 8
// triangles are loaded per row with one unaligned load (lanes past n read neighbouring rows or
// the padding at the end and are masked out).
//
// Eight triangles at a time go through the 8-wide watertight test (core/triangle_simd.hpp),
// bit-identical to the scalar one, which decides the lanes it hands back.
#include <cstdint>
#include <vector>

#include "splitray/core/huge_page_allocator.hpp"
#include "splitray/core/triangle.hpp"
#include "splitray/core/triangle_simd.hpp"

namespace splitray {

class KdLeafTriangles {
 public:
  static constexpr std::uint32_t kPadding = 16;  // floats after the last row

  KdLeafTriangles() = default;

  // Room for the rows of `refs` references in all (mapped once, zero padding at the end).
  void resize(std::size_t refs) { rows_.assign(9 * refs + kPadding, 0.0f); }

  // Writes the rows of the leaf whose n references start at `first` (ids: all references),
  // within the size of resize(). Leaves write disjoint rows, so they may be filled in parallel.
  void set_leaf(std::uint32_t first, std::uint32_t n, const std::uint32_t* ids,
                const Triangle* triangles) {
    float* rows = rows_.data() + 9 * std::size_t{first};
    for (std::uint32_t i = 0; i < n; ++i) {
      const Triangle& t = triangles[ids[first + i]];
      for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c) rows[(3 * k + c) * n + i] = t.vertex(k)[c];
    }
  }

  const float* leaf(std::uint32_t first) const { return rows_.data() + 9 * std::size_t{first}; }
  std::size_t bytes() const { return rows_.size() * sizeof(float); }

  // Triangle i of the leaf whose rows start at `rows` and hold n triangles.
  static Triangle triangle(const float* rows, std::uint32_t n, std::uint32_t i) {
    const auto at = [&](int k, int c) { return rows[(3 * k + c) * n + i]; };
    return {{at(0, 0), at(0, 1), at(0, 2)},
            {at(1, 0), at(1, 1), at(1, 2)},
            {at(2, 0), at(2, 1), at(2, 2)}};
  }

 private:
  HugePageVector<float> rows_;
};

// Tests the n triangles of a leaf (rows from KdLeafTriangles::leaf, primitive ids `ids`).
// Closest hit (kAnyHit false): updates `hit` under the tie rule of Hit with t in
// [tmin, hit.t]. Any hit: returns true as soon as a triangle is hit with t in [tmin, tmax].
template <bool kAnyHit>
inline bool intersect_leaf(const WatertightRay& r, const float* rows, const std::uint32_t* ids,
                           std::uint32_t n, float tmin, float tmax, Hit& hit) {
  const auto scalar_test = [&](std::uint32_t i) {
    const Triangle tri = KdLeafTriangles::triangle(rows, n, i);
    if constexpr (kAnyHit) {
      float t, tu, tv;
      return intersect_triangle(r, tri, tmin, tmax, t, tu, tv);
    } else {
      intersect_triangle(r, tri, ids[i], tmin, hit);
      return false;
    }
  };
#if defined(__AVX__)
  const Watertight8 test(r);
  const std::size_t stride = n;
  alignas(32) float ts[8], us[8], vs[8];
  for (std::uint32_t base = 0; base < n; base += 8) {
    const float* p = rows + base;
    const auto load = [&](int k, int c) { return simd::Float8::loadu(p + (3 * k + c) * stride); };
    const std::uint32_t lanes = n - base < 8 ? n - base : 8;
    unsigned scalar = 0;
    unsigned accept =
        test.test(load, (1u << lanes) - 1, tmin, kAnyHit ? tmax : hit.t, ts, us, vs, scalar);
    for (; scalar; scalar &= scalar - 1)  // decided in double by the scalar test
      if (scalar_test(base + static_cast<std::uint32_t>(__builtin_ctz(scalar)))) return true;
    if (!accept) continue;
    if constexpr (kAnyHit) return true;
    for (; accept; accept &= accept - 1) {
      const unsigned l = static_cast<unsigned>(__builtin_ctz(accept));
      const Hit candidate{ts[l], ids[base + l], us[l], vs[l]};
      if (candidate.closer_than(hit)) hit = candidate;
    }
  }
#else
  for (std::uint32_t i = 0; i < n; ++i)
    if (scalar_test(i)) return true;
#endif
  return kAnyHit ? false : hit.found();
}

}  // namespace splitray

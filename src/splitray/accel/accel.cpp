#include "splitray/accel/accel.hpp"

#include <algorithm>

#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

// A ray as the structures see it: a direction rescaled by 2^k, or untraceable.
struct Prepared {
  bool traceable;
  int exponent;
};

Prepared prepare(const Ray& ray) {
  if (!traceable(ray)) return {false, 0};
  return {true, direction_exponent(ray)};
}

Hit unscaled(Hit hit, int exponent) {
  if (exponent != 0 && hit.found()) hit.t = std::ldexp(hit.t, exponent);
  return hit;
}

void check_slots(std::size_t rays, std::size_t slots, const char* call) {
  if (slots < rays)
    throw Error(call,
                std::to_string(slots) + " result slots for " + std::to_string(rays) + " rays");
}

}  // namespace

Hit Accel::intersect(const Ray& ray) const {
  const Prepared p = prepare(ray);
  if (!p.traceable) return Hit{};
  if (p.exponent == 0) return closest_hit(ray);
  return unscaled(closest_hit(scaled_ray(ray, p.exponent)), p.exponent);
}

bool Accel::occluded(const Ray& ray) const {
  const Prepared p = prepare(ray);
  if (!p.traceable) return false;
  return any_hit(p.exponent == 0 ? ray : scaled_ray(ray, p.exponent));
}

// The batched calls hand the structure's fast paths the caller's array when every ray is in
// the domain as given (the common case), and otherwise the traceable rays, rescaled, as a
// compact copy whose answers are scattered back.
void Accel::intersect(std::span<const Ray> rays, std::span<Hit> hits) const {
  check_slots(rays.size(), hits.size(), "intersect");
  if (all_as_given(rays)) return closest_hits(rays, hits.first(rays.size()));
  std::vector<Ray> kept;
  std::vector<std::size_t> where;
  std::vector<int> exponents;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const Prepared p = prepare(rays[i]);
    hits[i] = Hit{};
    if (!p.traceable) continue;
    kept.push_back(p.exponent == 0 ? rays[i] : scaled_ray(rays[i], p.exponent));
    where.push_back(i);
    exponents.push_back(p.exponent);
  }
  std::vector<Hit> kept_hits(kept.size());
  if (!kept.empty()) closest_hits(kept, kept_hits);
  for (std::size_t j = 0; j < kept.size(); ++j)
    hits[where[j]] = unscaled(kept_hits[j], exponents[j]);
}

void Accel::occluded(std::span<const Ray> rays, std::span<std::uint8_t> result) const {
  check_slots(rays.size(), result.size(), "occluded");
  if (all_as_given(rays)) return any_hits(rays, result.first(rays.size()));
  std::vector<Ray> kept;
  std::vector<std::size_t> where;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const Prepared p = prepare(rays[i]);
    result[i] = 0;
    if (!p.traceable) continue;
    kept.push_back(p.exponent == 0 ? rays[i] : scaled_ray(rays[i], p.exponent));
    where.push_back(i);
  }
  std::vector<std::uint8_t> kept_result(kept.size());
  if (!kept.empty()) any_hits(kept, kept_result);
  for (std::size_t j = 0; j < kept.size(); ++j) result[where[j]] = kept_result[j];
}

void Accel::intersect_each(std::span<const Ray> rays, std::span<Hit> hits) const {
  check_slots(rays.size(), hits.size(), "intersect");
  parallel_chunks(rays.size(), 256, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) hits[i] = intersect(rays[i]);
  });
}

void Accel::occluded_each(std::span<const Ray> rays, std::span<std::uint8_t> result) const {
  check_slots(rays.size(), result.size(), "occluded");
  parallel_chunks(rays.size(), 256, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) result[i] = occluded(rays[i]) ? 1 : 0;
  });
}

bool Accel::refit(std::span<const Triangle> triangles) {
  check_triangles(triangles, "refit");
  return refit_to(triangles);
}

void Accel::closest_hits(std::span<const Ray> rays, std::span<Hit> hits) const {
  parallel_chunks(rays.size(), 256, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) hits[i] = closest_hit(rays[i]);
  });
}

void Accel::any_hits(std::span<const Ray> rays, std::span<std::uint8_t> result) const {
  parallel_chunks(rays.size(), 256, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) result[i] = any_hit(rays[i]) ? 1 : 0;
  });
}

}  // namespace splitray

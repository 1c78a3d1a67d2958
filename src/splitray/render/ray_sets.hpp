#pragma once
// Reproducible ray sets for `trace`, tests and benchmarks: they depend only on the triangles,
// the kind, the seed, the camera and the count, never on the structure traced.
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "splitray/core/camera.hpp"
#include "splitray/core/triangle.hpp"

namespace splitray {

enum class RayKind { primary, random, diffuse };

RayKind parse_ray_kind(const std::string& name);  // throws Error on an unknown name

// primary: through a jittered grid of pixels of `camera` (default: Camera::frame of the bounds);
// random: uniform origins in the bounding box, uniform directions;
// diffuse: from the primary hits, cosine-distributed about the surface normal facing the ray;
//   where primary ray i misses, ray i re-draws its pixel at random (its own generator, at
//   most 256 times; Error if all miss), so every set has exactly `count` rays.
// Each ray comes from its own generator seeded by (seed, index): the same for any thread count.
std::vector<Ray> make_rays(std::span<const Triangle> triangles, RayKind kind, std::uint64_t seed,
                           std::size_t count, const std::optional<Camera>& camera = std::nullopt);

}  // namespace splitray

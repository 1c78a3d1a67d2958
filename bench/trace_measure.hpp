#pragma once
// What the tracing benchmarks (build-trace, bvh) share: timed passes over a ray set, hit
// checksums, and the camera as the reports show it.
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <span>
#include <string>

#include "splitray/core/camera.hpp"
#include "splitray/core/ray.hpp"

namespace splitray::bench {

// Median Mrays/s of `runs` timed passes of `pass` over `count` rays, after one warm-up pass:
// {"mrays_per_s", "ms", "ms_runs"}.
nlohmann::ordered_json throughput(std::size_t count, int runs, const std::function<void()>& pass);

struct Checksum {
  std::uint64_t hits = 0, id_checksum = 0;  // id_checksum: sum of (prim + 1), as `trace`
};
Checksum checksum(std::span<const Hit> hits);

// Rays whose closest hits name different primitives.
std::size_t differing(std::span<const Hit> a, std::span<const Hit> b);

nlohmann::ordered_json camera_json(const Camera& c, const std::string& view);

}  // namespace splitray::bench

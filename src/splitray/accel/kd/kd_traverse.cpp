// The kd-tree's queries: single rays through the walk (kd_wide_traverse.cpp), batches as
// packets of coherent rays (kd_packet.cpp) and interleaved walks for the others.
#include <algorithm>
#include <limits>
#include <vector>

#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

Hit KdAccel::closest_hit(const Ray& ray) const {
  Hit hit;
  if (!traverse<false>(ray, hit)) hit = Hit{};
  return hit;
}

bool KdAccel::any_hit(const Ray& ray) const {
  Hit unused;
  return traverse<true>(ray, unused);
}

void KdAccel::closest_hits(std::span<const Ray> rays, std::span<Hit> hits) const {
  if (hits.size() < rays.size()) throw Error("kd intersect", "fewer hit slots than rays");
  if (rays.size() > std::numeric_limits<std::uint32_t>::max())
    throw Error("kd intersect", "more than 2^32 - 1 rays in one call");
  parallel_chunks(rays.size(), 256, [&](std::size_t begin, std::size_t end) {
    // Coherent groups as packets (starting at multiples of the packet size, so the same
    // rays share a packet for any chunking); the other rays in interleaved single-ray walks.
    std::vector<std::uint32_t> rest;
    rest.reserve(end - begin);
    constexpr std::size_t kGroup = kPacketRays;
    for (std::size_t i = begin; i < end;) {
      const unsigned done = i % kGroup == 0 && i + kGroup <= end
                                ? intersect_packets(rays.data() + i, hits.data() + i)
                                : 0u;
      const std::size_t group_end = std::min(end, (i / kGroup + 1) * kGroup);
      for (; i < group_end; ++i)
        if (!(done >> ((i % kGroup) / 8) & 1)) rest.push_back(static_cast<std::uint32_t>(i));
    }
    walk_interleaved<false>(rays.data(), rest.data(), rest.size(), hits.data(), nullptr);
  });
}

void KdAccel::any_hits(std::span<const Ray> rays, std::span<std::uint8_t> result) const {
  if (result.size() < rays.size()) throw Error("kd occluded", "fewer result slots than rays");
  if (rays.size() > std::numeric_limits<std::uint32_t>::max())
    throw Error("kd occluded", "more than 2^32 - 1 rays in one call");
  parallel_chunks(rays.size(), 256, [&](std::size_t begin, std::size_t end) {
    std::vector<std::uint32_t> all(end - begin);
    for (std::size_t i = begin; i < end; ++i) all[i - begin] = static_cast<std::uint32_t>(i);
    walk_interleaved<true>(rays.data(), all.data(), all.size(), nullptr, result.data());
  });
}

}  // namespace splitray

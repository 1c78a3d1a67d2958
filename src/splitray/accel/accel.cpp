#include "splitray/accel/accel.hpp"

#include "splitray/core/parallel.hpp"

namespace splitray {

void Accel::intersect(std::span<const Ray> rays, std::span<Hit> hits) const {
  parallel_chunks(rays.size(), 256, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) hits[i] = intersect(rays[i]);
  });
}

void Accel::occluded(std::span<const Ray> rays, std::span<std::uint8_t> result) const {
  parallel_chunks(rays.size(), 256, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) result[i] = occluded(rays[i]) ? 1 : 0;
  });
}

}  // namespace splitray

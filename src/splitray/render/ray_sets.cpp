#include "splitray/render/ray_sets.hpp"

#include <cmath>

#include "splitray/accel/accel.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/random.hpp"
#include "splitray/render/surface.hpp"

namespace splitray {

namespace {

// The aspect ratio of the image the primary grid stands for (the default 800x600).
constexpr float kAspect = 4.0f / 3.0f;
// A diffuse ray re-draws its primary pixel at random at most this many times when the
// primary ray misses everything, then the whole set is refused.
constexpr int kDiffuseAttempts = 256;

std::uint64_t splitmix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// Every ray has its own generator, so that generation is parallel and each ray depends only
// on (seed, index), never on the thread count.
Pcg32 ray_rng(std::uint64_t seed, std::size_t index) {
  return Pcg32(splitmix64(seed ^ splitmix64(static_cast<std::uint64_t>(index))));
}

struct PrimaryGrid {
  int width, height;
  explicit PrimaryGrid(std::size_t count) {
    width =
        std::max(1, static_cast<int>(std::ceil(std::sqrt(static_cast<double>(count) * kAspect))));
    height = std::max(1, static_cast<int>((count + width - 1) / width));
  }
  // Ray through grid pixel `index` (row-major, wrapping), jittered inside the pixel.
  Ray ray(const Camera& camera, std::size_t index, Pcg32& rng) const {
    const auto pixel = index % (static_cast<std::size_t>(width) * height);
    const float x = static_cast<float>(pixel % width) + rng.next_float();
    const float y = static_cast<float>(pixel / width) + rng.next_float();
    return camera.generate(x, y, width, height);
  }
  Ray random_ray(const Camera& camera, Pcg32& rng) const {
    const float x = rng.next_float() * static_cast<float>(width);
    const float y = rng.next_float() * static_cast<float>(height);
    return camera.generate(x, y, width, height);
  }
};

template <typename Make>
std::vector<Ray> generate(std::size_t count, const Make& make) {
  std::vector<Ray> rays(count);
  parallel_chunks(count, 1024, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) rays[i] = make(i);
  });
  return rays;
}

}  // namespace

RayKind parse_ray_kind(const std::string& name) {
  if (name == "primary") return RayKind::primary;
  if (name == "random") return RayKind::random;
  if (name == "diffuse") return RayKind::diffuse;
  throw Error("--rays", "unknown ray kind '" + name + "' (known: primary, random, diffuse)");
}

std::vector<Ray> make_rays(std::span<const Triangle> triangles, RayKind kind, std::uint64_t seed,
                           std::size_t count, const std::optional<Camera>& camera) {
  if (triangles.empty()) throw Error("rays", "no triangles to make rays for");
  const Aabb box = bounds_of(triangles);
  const Camera cam = camera ? *camera : Camera::frame(box);
  const PrimaryGrid grid(count);

  switch (kind) {
    case RayKind::primary:
      return generate(count, [&](std::size_t i) {
        Pcg32 rng = ray_rng(seed, i);
        return grid.ray(cam, i, rng);
      });
    case RayKind::random:
      return generate(count, [&](std::size_t i) {
        Pcg32 rng = ray_rng(seed, i);
        const Vec3 e = box.extent();
        const float ux = rng.next_float(), uy = rng.next_float(), uz = rng.next_float();
        const Vec3 org = box.lo + Vec3{e.x * ux, e.y * uy, e.z * uz};
        const float u1 = rng.next_float(), u2 = rng.next_float();
        return Ray{org, uniform_sphere(u1, u2)};
      });
    case RayKind::diffuse: {
      // The primary hits come from one fixed structure, so the set never depends on the
      // structure that will trace it.
      BuildConfig config;
      config.builder = "sah";
      const auto accel = make_accel("kd", triangles, config);
      const float eps = offset_epsilon(box);
      return generate(count, [&](std::size_t i) {
        Pcg32 rng = ray_rng(seed, i);
        // First the grid pixel of ray i (as in the primary set); when that primary ray misses,
        // further pixels drawn at random from the same generator.
        Ray primary = grid.ray(cam, i, rng);
        for (int attempt = 0; attempt < kDiffuseAttempts; ++attempt) {
          if (attempt > 0) primary = grid.random_ray(cam, rng);
          const Hit hit = accel->intersect(primary);
          if (!hit.found()) continue;
          const Triangle& tri = triangles[hit.prim];
          Vec3 n = normalize(tri.geometric_normal());
          if (dot(n, primary.dir) > 0) n = -n;  // face the incoming ray
          const float u1 = rng.next_float(), u2 = rng.next_float();
          return Ray{hit_position(tri, hit) + n * eps, cosine_hemisphere(n, u1, u2)};
        }
        throw Error("--rays diffuse", "the camera sees almost none of the triangles (" +
                                          std::to_string(kDiffuseAttempts) +
                                          " primary rays in a row missed)");
      });
    }
  }
  throw Error("--rays", "unknown ray kind");
}

}  // namespace splitray

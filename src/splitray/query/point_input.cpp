#include "splitray/query/point_input.hpp"

#include "splitray/core/aabb.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/random.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/query/neighbors.hpp"
#include "splitray/query/point_io.hpp"
#include "splitray/query/surface_sampling.hpp"

namespace splitray {

PointInput load_point_input(const std::string& path, std::size_t samples, std::uint64_t seed) {
  PointInput input;
  input.path = path;
  if (is_point_file(path)) {
    input.points = load_points(path);
  } else {
    if (samples == 0) throw Error(path, "the mesh is sampled with 0 points (see --samples)");
    input.mesh = load_mesh(path);
    if (input.mesh->name.empty()) input.mesh->name = path;
    input.points = sample_surface(*input.mesh, samples, seed, kPointStream);
  }
  check_points(input.points, path.c_str());
  return input;
}

std::vector<Vec3> make_queries(const PointInput& input, std::size_t count, std::uint64_t seed) {
  if (input.mesh) return sample_surface(*input.mesh, count, seed, kQueryStream);
  Aabb box;
  for (const Vec3& p : input.points) box.extend(p);
  const float jitter = 1e-3f * length(box.extent());
  Pcg32 rng(seed, kQueryStream);
  std::vector<Vec3> queries(count);
  for (Vec3& q : queries) {
    const std::uint64_t r = (static_cast<std::uint64_t>(rng.next_u32()) << 32) | rng.next_u32();
    q = input.points[r % input.points.size()];
    for (int a = 0; a < 3; ++a) q[a] += jitter * (2 * rng.next_float() - 1);
  }
  return queries;
}

}  // namespace splitray

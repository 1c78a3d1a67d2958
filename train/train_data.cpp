#include "train_data.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "greedy_top.hpp"
#include "splitray/accel/neural/neural_sampling.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/random.hpp"
#include "splitray/io/mesh_io.hpp"

namespace splitray::train {

namespace {

struct Pool {
  std::vector<Vec3> points;
  Aabb bounds;
  double population = 0;  // what the whole pool stands for
};

Pool make_pool(const std::string& file, const DataOptions& options, std::uint64_t seed) {
  const Mesh mesh = load_mesh(file);
  mesh.validate(file);
  const std::vector<Triangle> triangles = mesh.triangles();
  Pool pool;
  pool.points = SurfaceSampler(triangles).sample(options.pool, seed);
  pool.bounds = mesh.bounds();
  pool.population =
      options.cost == NeuralCost::sah ? static_cast<double>(triangles.size()) : options.vvh_points;
  return pool;
}

// Rotation by a uniformly random unit quaternion (Shoemake), as a 3x3 row-major matrix.
std::array<float, 9> random_rotation(Pcg32& rng) {
  const double u1 = rng.next_float(), u2 = rng.next_float(), u3 = rng.next_float();
  const double a = std::sqrt(1 - u1), b = std::sqrt(u1);
  const double w = a * std::sin(2 * std::numbers::pi * u2),
               x = a * std::cos(2 * std::numbers::pi * u2);
  const double y = b * std::sin(2 * std::numbers::pi * u3),
               z = b * std::cos(2 * std::numbers::pi * u3);
  return {static_cast<float>(1 - 2 * (y * y + z * z)), static_cast<float>(2 * (x * y - z * w)),
          static_cast<float>(2 * (x * z + y * w)),     static_cast<float>(2 * (x * y + z * w)),
          static_cast<float>(1 - 2 * (x * x + z * z)), static_cast<float>(2 * (y * z - x * w)),
          static_cast<float>(2 * (x * z - y * w)),     static_cast<float>(2 * (y * z + x * w)),
          static_cast<float>(1 - 2 * (x * x + y * y))};
}

float radius_of(const Aabb& box, const DataOptions& options) {
  // The paper trains the VVH once with r = 1e-4 (of the scene size): relative to the cell.
  return options.cost == NeuralCost::vvh ? 1e-4f * length(box.extent()) : 0.0f;
}

TrainSet draw(const std::vector<Vec3>& inside, const Aabb& cell, double population, Pcg32& rng,
              const DataOptions& options) {
  TrainSet set;
  set.points.reserve(static_cast<std::size_t>(options.points));
  for (int k = 0; k < options.points; ++k)
    set.points.push_back(inside[rng.next_u32() % inside.size()]);
  set.root = cell;
  set.population = population;
  set.radius = radius_of(cell, options);
  return set;
}

}  // namespace

std::vector<TrainSet> build_training_sets(const std::vector<std::string>& files,
                                          const DataOptions& options) {
  std::vector<TrainSet> sets;
  for (std::size_t f = 0; f < files.size(); ++f) {
    const std::uint64_t seed = options.seed * 1000003u + f;
    const Pool pool = make_pool(files[f], options, seed);
    Pcg32 rng(seed, 0x7261696e);
    // The shallow greedy tree, built on a subsample of the pool (its splits only select cells).
    std::vector<Vec3> sub;
    for (std::size_t i = 0; i < pool.points.size() && sub.size() < 16384; i += 8)
      sub.push_back(pool.points[i]);
    NeuralTopOptions top_options;
    top_options.cost = options.cost;
    top_options.traversal_cost = options.traversal_cost;
    top_options.intersection_cost = options.intersection_cost;
    top_options.radius = radius_of(pool.bounds, options);
    top_options.population = pool.population;
    top_options.max_depth = options.tree_depth;
    const NeuralTop shallow = greedy_top(sub, pool.bounds, top_options);
    std::vector<int> node_depth(shallow.nodes.size(), 0);  // children come after parents
    for (std::size_t n = 0; n < shallow.nodes.size(); ++n)
      if (!shallow.nodes[n].leaf())
        for (const std::int32_t c : shallow.nodes[n].child)
          node_depth[static_cast<std::size_t>(c)] = node_depth[n] + 1;

    for (std::size_t n = 0; n < shallow.nodes.size(); ++n) {
      const Aabb cell = shallow.nodes[n].box;
      std::vector<Vec3> inside;
      for (const Vec3& p : pool.points)
        if (cell.contains(p)) inside.push_back(p);
      if (inside.size() < static_cast<std::size_t>(options.points)) continue;  // too sparse
      const double population =
          pool.population * static_cast<double>(inside.size()) / pool.points.size();
      const std::string where = files[f] + " node " + std::to_string(n);
      sets.push_back(draw(inside, cell, population, rng, options));
      sets.back().source = where;
      sets.back().level = options.levels_from_nodes ? node_depth[n] : 0;
      for (int r = 0; r < options.rotations; ++r) {
        const std::array<float, 9> m = random_rotation(rng);
        const Vec3 c = cell.center();
        TrainSet set = draw(inside, cell, population, rng, options);
        Aabb bounds;
        for (Vec3& p : set.points) {
          const Vec3 d = p - c;
          p = c + Vec3{m[0] * d.x + m[1] * d.y + m[2] * d.z, m[3] * d.x + m[4] * d.y + m[5] * d.z,
                       m[6] * d.x + m[7] * d.y + m[8] * d.z};
          bounds.extend(p);
        }
        set.root = bounds;
        set.radius = radius_of(bounds, options);
        set.source = where + " rotation " + std::to_string(r + 1);
        set.level = options.levels_from_nodes ? node_depth[n] : 0;
        sets.push_back(std::move(set));
      }
    }
  }
  if (sets.empty()) throw Error("--data", "no training sets (meshes too small for --samples?)");
  return sets;
}

std::vector<TrainSet> whole_mesh_sets(const std::vector<std::string>& files,
                                      const DataOptions& options, int per_mesh) {
  std::vector<TrainSet> sets;
  for (std::size_t f = 0; f < files.size(); ++f) {
    const Mesh mesh = load_mesh(files[f]);
    mesh.validate(files[f]);
    const std::vector<Triangle> triangles = mesh.triangles();
    const SurfaceSampler sampler(triangles);
    for (int k = 0; k < per_mesh; ++k) {
      TrainSet set;
      set.points = sampler.sample(static_cast<std::size_t>(options.points),
                                  options.seed * 7919u + f * 131u + static_cast<unsigned>(k));
      set.root = mesh.bounds();
      set.population = options.cost == NeuralCost::sah ? static_cast<double>(triangles.size())
                                                       : options.vvh_points;
      set.radius = radius_of(set.root, options);
      set.source = files[f] + " whole mesh " + std::to_string(k);
      sets.push_back(std::move(set));
    }
  }
  return sets;
}

}  // namespace splitray::train

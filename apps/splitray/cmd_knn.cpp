// splitray knn INPUT --k K --queries N --seed S [--radius R]: nearest-neighbour search over a
// point file or the area-weighted surface samples of a mesh (paper 003 §6.1, §6.3), with
// queries reproducible from the seed. Prints checksums that every correct structure agrees
// on (neighbor_checksum: ours, ties broken by index; dist_sum: everyone) and the speed.
#include <fmt/core.h>

#include <cstdint>
#include <memory>
#include <optional>

#include "commands.hpp"
#include "file_options.hpp"
#include "json_output.hpp"
#include "options.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/memory_budget.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/io/npy.hpp"
#include "splitray/query/neighbor_index.hpp"
#include "splitray/query/point_input.hpp"

namespace splitray::app {

namespace {

struct KnnCommand {
  std::string input;
  int k = 8;
  std::size_t queries = 100000;
  std::uint64_t seed = 1;
  std::optional<double> radius;  // parsed as given; searched as float
  std::size_t samples = 1000000;
  NeighborIndexConfig index;
  int threads = 0;
  std::string queries_in, out;  // the user's queries (.npy), the neighbours written (.npz)
  cli::JsonOutput json;
};

bool is_npy(const std::string& path) {
  return path.size() >= 4 && (path.ends_with(".npy") || path.ends_with(".NPY"));
}

std::vector<Vec3> read_points(const std::string& path, const std::string& what) {
  const FloatArray a = read_npy_rows(path, 3, what + " (x, y, z)");
  std::vector<Vec3> points(a.shape[0]);
  for (std::size_t i = 0; i < points.size(); ++i)
    points[i] = {a.values[3 * i], a.values[3 * i + 1], a.values[3 * i + 2]};
  return points;
}

// --out: scipy cKDTree.query's answer with Open3D-style padding: indices N x K int64 (-1
// where fewer than K points exist), distances N x K float32, Euclidean (inf where fewer).
void write_neighbors(const std::string& path, const KnnResult& result, std::size_t queries, int k) {
  const auto kk = static_cast<std::size_t>(k);
  std::vector<std::int64_t> indices(queries * kk, -1);
  std::vector<float> distances(queries * kk, kInfinity);
  for (std::size_t q = 0; q < queries; ++q) {
    const auto ids = result.indices_of(q);
    const auto ds = result.distances_of(q);
    for (std::size_t j = 0; j < ids.size() && j < kk; ++j) {
      indices[q * kk + j] = ids[j];
      distances[q * kk + j] = ds[j];
    }
  }
  write_npz(path, {{"indices", npy_array({queries, kk}, indices)},
                   {"distances", npy_array({queries, kk}, distances)}});
}

void run(const KnnCommand& command) {
  const float radius = command.radius ? static_cast<float>(*command.radius) : 0.0f;
  if (command.radius) check_radius(radius, "--radius");
  if (!command.radius && command.k < 1)
    throw Error("--k", "k must be at least 1 (got " + std::to_string(command.k) + ")");
  if (!command.out.empty()) {
    if (command.radius)
      throw Error("--out", "writes k-nearest answers (N x K arrays): use --k, not --radius");
    check_output_path(command.out, ".npz");
  }
  const ThreadLimit limit(command.threads);
  check_memory(command.samples, sizeof(Vec3) * 4, std::to_string(command.samples) + " samples",
               "--samples");
  if (command.queries_in.empty())
    check_memory(command.queries, sizeof(Vec3) * 2, std::to_string(command.queries) + " queries",
                 "--queries");
  const Timer load_timer;
  PointInput input;
  if (is_npy(command.input)) {
    input.path = command.input;
    input.points = read_points(command.input, "points");
  } else {
    input = load_point_input(command.input, command.samples, command.seed);
  }
  const std::vector<Vec3> queries = command.queries_in.empty()
                                        ? make_queries(input, command.queries, command.seed)
                                        : read_points(command.queries_in, "queries");
  const double load_ms = load_timer.ms();
  // With --out, K may exceed the points: the missing neighbours are padded.
  const int k = command.out.empty()
                    ? command.k
                    : static_cast<int>(std::min<std::size_t>(command.k, input.points.size()));
  if (!command.radius) {
    check_k(k, input.points.size(), "--k");
    check_memory(queries.size() * static_cast<std::size_t>(k), command.out.empty() ? 8 : 24,
                 "the k nearest of every query", "--k");
  }

  NeighborIndexConfig config = command.index;
  // A radius search builds the VVH for that radius (paper 003 §6.3), unless told otherwise.
  if (command.radius && !(config.radius > 0) && radius > 0) config.radius = radius;
  const auto index = make_neighbor_index(input.points, config);

  const Timer query_timer;
  NeighborSummary summary;
  if (command.radius) {
    summary = summarize(index->radius(queries, radius));
  } else {
    const KnnResult result = index->knn(queries, k);
    if (!command.out.empty()) write_neighbors(command.out, result, queries.size(), command.k);
    summary = summarize(result);
  }
  const double ms = query_timer.ms();
  const double queries_per_s = ms > 0 ? static_cast<double>(queries.size()) / (ms / 1000) : 0.0;

  if (command.json.wanted()) {
    nlohmann::ordered_json object;
    object["points"] = input.points.size();
    object["queries"] = queries.size();
    object["k"] =
        command.radius ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(command.k);
    object["build_ms"] = index->build_ms();
    object["ms"] = ms;
    object["queries_per_s"] = queries_per_s;
    object["neighbor_checksum"] = summary.checksum;
    object["dist_sum"] = summary.dist_sum;
    object["mean_dist"] = summary.mean_dist;
    object["builder"] = index->name();
    if (command.radius) object["radius"] = *command.radius;
    object["neighbors"] = summary.neighbors;
    object["input"] = command.input;
    object["sampled"] = input.mesh.has_value();
    object["seed"] = command.seed;
    object["leaf_size"] = config.leaf_size;
    object["threads"] = effective_threads(command.threads);
    object["load_ms"] = load_ms;
    if (const PointTree* tree = index->tree()) {
      const PointTreeStats stats = tree->stats();
      object["vvh_radius"] = stats.radius;
      object["vvh_cost"] = stats.vvh_cost;
      object["nodes"] = stats.nodes;
      object["leaves"] = stats.leaves;
      object["max_depth"] = stats.max_depth;
      object["bytes"] = stats.bytes;
      if (stats.inference_ms) {  // --builder neural
        object["inference_ms"] = *stats.inference_ms;
        object["top_depth"] = stats.top_depth;
      }
    }
    cli::emit_json(command.json, object);
    if (command.json.print) return;
  }
  fmt::print("splitray knn: {} over {} ({} points{})\n", index->name(), command.input,
             input.points.size(), input.mesh ? ", surface samples" : "");
  std::vector<std::pair<std::string, std::string>> rows = {
      {"search", command.radius ? fmt::format("radius {}", *command.radius)
                                : fmt::format("{} nearest", command.k)},
      {"queries", std::to_string(queries.size())},
      {"build_ms", fmt::format("{:.2f}", index->build_ms())},
      {"ms", fmt::format("{:.2f}", ms)},
      {"queries_per_s", fmt::format("{:.0f}", queries_per_s)},
      {"neighbors", std::to_string(summary.neighbors)},
      {"neighbor_checksum", std::to_string(summary.checksum)},
      {"dist_sum", fmt::format("{:.9g}", summary.dist_sum)},
      {"mean_dist", fmt::format("{:.9g}", summary.mean_dist)},
      {"threads", std::to_string(effective_threads(command.threads))},
  };
  print_table(rows);
}

}  // namespace

void add_knn_command(CLI::App& app) {
  auto command = std::make_shared<KnnCommand>();
  CLI::App* sub = app.add_subcommand(
      "knn", "k-nearest or radius search over a point file or a mesh's surface samples");
  sub->add_option("INPUT", command->input,
                  "Points (*.ply without faces, *.xyz/*.txt/*.pts: x y z per line, *.npy: N x 3 "
                  "floats) or a mesh (any format of render, also *.gz) sampled area-weighted")
      ->required();
  sub->add_option("--k", command->k, "Neighbours per query (k-nearest search)");
  sub->add_option("--queries", command->queries,
                  "Query count: surface samples of the mesh (or jittered input points), from "
                  "--seed on a stream of their own");
  sub->add_option("--seed", command->seed, "Seed of the samples and queries");
  sub->add_option("--queries-in", command->queries_in,
                  "Your own queries instead: a NumPy .npy file of N x 3 floats (float32 or "
                  "float64)");
  sub->add_option("--out", command->out,
                  "Write the k nearest of every query to this .npz: indices (N x K int64, -1 "
                  "where the input has fewer than K points) and distances (N x K float32, "
                  "Euclidean, inf where fewer), nearest first");
  sub->add_option("--radius", command->radius,
                  "Radius search instead: every point within this distance (<=), sorted");
  sub->add_option("--samples", command->samples, "Points sampled from a mesh's surface")
      ->check(CLI::PositiveNumber);
  std::vector<std::string> names = neighbor_index_names();
  names.push_back("neural");
  sub->add_option("--builder", command->index.builder,
                  "vvh, sah, median (ours), neural (paper 003: inferred top + --expand), brute "
                  "(oracle), nanoflann or flann (yardsticks)")
      ->check(CLI::IsMember(names));
  sub->add_option("--model", command->index.neural.model,
                  "--builder neural: model file (default: models/vvh.bin of the source tree, "
                  "$SPLITRAY_MODEL_DIR or share/splitray/models)");
  sub->add_option("--expand", command->index.neural.expand,
                  "--builder neural: builder of the inferred top's leaf cells (vvh, sah, median; "
                  "default vvh)")
      ->check(CLI::IsMember({"vvh", "sah", "median"}));
  sub->add_option("--top-min", command->index.neural.top_min,
                  "--builder neural: inferred-top cells of fewer points (estimated from the "
                  "samples) are left to the expansion builder (default 4096; 0: split down to the "
                  "model's depth)")
      ->check(CLI::Range(0, 1 << 30));
  sub->add_flag("--greedy-top", command->index.neural.greedy_top,
                "--builder neural: the top from an exact greedy VVH sweep over the same samples "
                "instead of the network (paper 003 Fig. 3's baseline)");
  sub->add_option("--leaf-size", command->index.leaf_size, "Points per leaf (all trees)")
      ->check(CLI::Range(1, 1 << 20));
  sub->add_option("--vvh-radius", command->index.radius,
                  "VVH/SAH cell expansion (0: --radius, else 1e-4 of the bounding-box diagonal)");
  sub->add_option("--threads", command->threads, "Worker threads (0 = all cores)")
      ->check(CLI::NonNegativeNumber);
  cli::add_json_options(
      *sub, command->json,
      "points, queries, k (null for --radius), build_ms, ms, "
      "queries_per_s, neighbor_checksum, dist_sum, mean_dist, builder, radius (with "
      "--radius), neighbors, input, sampled, seed, leaf_size, threads, load_ms, and for "
      "our trees vvh_radius, vvh_cost, nodes, leaves, max_depth, bytes (and inference_ms, "
      "top_depth for --builder neural)");
  cli::input_files(sub->get_option("INPUT"));
  cli::input_files(sub->get_option("--queries-in"));
  cli::input_files(sub->get_option("--model"));
  cli::output_file(sub->get_option("--out"));
  sub->callback([command] { run(*command); });
}

}  // namespace splitray::app

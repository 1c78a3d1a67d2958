#include "knn_bench.hpp"

#include <fmt/core.h>
#include <sys/resource.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <map>

#include "bench_meshes.hpp"
#include "bench_report.hpp"
#include "machine.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/image.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/query/neighbor_index.hpp"
#include "splitray/query/surface_sampling.hpp"

namespace splitray::bench {

namespace {

using json = nlohmann::ordered_json;

struct KnnMesh {
  std::string name, path;
};

// CPU time of the whole process (all threads), ms: on a busy machine wall time says more
// about the other work than about ours, so reports carry both.
double cpu_ms() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto ms = [](const timeval& t) { return t.tv_sec * 1e3 + t.tv_usec * 1e-3; };
  return ms(usage.ru_utime) + ms(usage.ru_stime);
}

std::string vendored(const std::string& relative) {
  return (std::filesystem::path(SPLITRAY_SOURCE_DIR) / "data" / relative).string();
}

// Named meshes: the paper's kind of input (objects and an interior) from ../shared/data,
// the vendored meshes when shared data is absent.
std::vector<KnnMesh> knn_meshes(const KnnBenchOptions& options, std::vector<std::string>& notes) {
  const std::string shared = shared_data_dir();
  const auto shared_file = [&](const std::string& relative) {
    const auto path = std::filesystem::path(shared) / relative;
    return !shared.empty() && std::filesystem::exists(path) ? path.string() : std::string{};
  };
  const std::map<std::string, std::string> named = {
      {"dragon", shared_file("static_dragon_100k/dragon.obj")},
      {"sibenik", shared_file("static_sibenik/sibenik.obj")},
      {"cat", shared_file("static_sumner_cat_lion_poses/cat-poses/cat-reference.obj.gz")},
      {"horse", vendored("horse/horse.obj.gz")},
      {"dragon-vendored", vendored("dragon_100k/dragon.obj.gz")}};
  std::vector<std::string> wanted = options.meshes;
  if (wanted.empty()) {
    wanted = options.quick ? std::vector<std::string>{"horse", "dragon-vendored"}
                           : std::vector<std::string>{"dragon", "sibenik", "cat"};
  }
  std::vector<KnnMesh> meshes;
  for (const std::string& name : wanted) {
    const auto it = named.find(name);
    if (it == named.end()) {
      if (!std::filesystem::exists(name))
        throw Error("--meshes", "'" + name +
                                    "' is neither dragon, sibenik, cat, horse, "
                                    "dragon-vendored nor an existing file");
      meshes.push_back({std::filesystem::path(name).filename().string(), name});
    } else if (it->second.empty()) {
      notes.push_back(name + ": shared data absent, skipped");
    } else {
      meshes.push_back({name, it->second});
    }
  }
  if (meshes.empty()) {
    notes.push_back("no shared meshes: the vendored horse and dragon instead");
    meshes = {{"horse", named.at("horse")}, {"dragon-vendored", named.at("dragon-vendored")}};
  }
  return meshes;
}

NeighborIndexConfig config_of(const std::string& structure, const KnnBenchOptions& options) {
  NeighborIndexConfig config;
  const auto plus = structure.find("+order");
  config.builder = structure.substr(0, plus);
  config.coherent_peers = plus != std::string::npos;
  config.leaf_size = options.leaf_size;
  return config;
}

bool is_ours(const std::string& builder) {
  return builder == "vvh" || builder == "sah" || builder == "median";
}

// Median ms of `runs` timed calls after one untimed warm-up; the answers of the warm-up are
// summarised for the agreement checks.
template <typename Run>
json measure(int runs, std::size_t queries, const Run& run) {
  const NeighborSummary summary = run();
  std::vector<double> ms, cpu;
  for (int r = 0; r < runs; ++r) {
    const double cpu_start = cpu_ms();
    const Timer timer;
    run();
    ms.push_back(timer.ms());
    cpu.push_back(cpu_ms() - cpu_start);
  }
  const double m = median(ms), c = median(cpu);
  return {{"ms", m},
          {"runs_ms", ms},
          {"queries_per_s", static_cast<double>(queries) / (m / 1000)},
          {"cpu_ms", c},
          {"queries_per_cpu_s", static_cast<double>(queries) / (c / 1000)},
          {"neighbors", summary.neighbors},
          {"neighbor_checksum", summary.checksum},
          {"dist_sum", summary.dist_sum},
          {"mean_dist", summary.mean_dist}};
}

json run_mesh(const KnnMesh& mesh, const KnnBenchOptions& options, std::size_t points_count,
              std::size_t query_count, int runs, bool& all_agree) {
  const Timer load_timer;
  Mesh geometry = load_mesh(mesh.path);
  const std::vector<Vec3> points =
      sample_surface(geometry, points_count, options.seed, kPointStream);
  const std::vector<Vec3> queries =
      sample_surface(geometry, query_count, options.seed, kQueryStream);
  Aabb box;
  for (const Vec3& p : points) box.extend(p);
  const float diagonal = length(box.extent());
  const float radius = static_cast<float>(options.radius_fraction) * diagonal;
  json out = {{"mesh", mesh.name},
              {"path", mesh.path},
              {"triangles", geometry.triangle_count()},
              {"points", points.size()},
              {"queries", queries.size()},
              {"diagonal", diagonal},
              {"radius", radius},
              {"load_and_sample_ms", load_timer.ms()}};
  geometry = Mesh{};

  json structures = json::object();
  for (const std::string& structure : options.structures) {
    fmt::print(stderr, "knn bench: {} {}\n", mesh.name, structure);
    const NeighborIndexConfig config = config_of(structure, options);
    std::vector<double> build_ms, build_cpu_ms;
    std::unique_ptr<NeighborIndex> index;
    for (int r = 0; r < runs; ++r) {
      index.reset();
      const double cpu_start = cpu_ms();
      index = make_neighbor_index(points, config);
      build_cpu_ms.push_back(cpu_ms() - cpu_start);
      build_ms.push_back(index->build_ms());
    }
    json row = {
        {"builder", config.builder},
        {"query_order", is_ours(config.builder) || config.coherent_peers ? "morton" : "given"},
        {"build_ms", median(build_ms)},
        {"build_runs_ms", build_ms},
        {"build_cpu_ms", median(build_cpu_ms)}};
    if (const PointTree* tree = index->tree()) {
      const PointTreeStats stats = tree->stats();
      row["tree"] = {{"nodes", stats.nodes},         {"leaves", stats.leaves},
                     {"max_depth", stats.max_depth}, {"mean_leaf_points", stats.mean_leaf_points},
                     {"vvh_cost", stats.vvh_cost},   {"vvh_radius", stats.radius},
                     {"bytes", stats.bytes}};
    }
    for (int k : options.ks)
      row["k" + std::to_string(k)] =
          measure(runs, queries.size(), [&] { return summarize(index->knn(queries, k)); });
    // Our VVH/SAH trees answer radius searches with a tree built for that radius (paper 003
    // §6.3); its build time is reported beside the search.
    std::unique_ptr<NeighborIndex> radius_index;
    if (config.builder == "vvh" || config.builder == "sah") {
      NeighborIndexConfig radius_config = config;
      radius_config.radius = radius;
      index.reset();
      radius_index = make_neighbor_index(points, radius_config);
    }
    const NeighborIndex& searcher = radius_index ? *radius_index : *index;
    row["radius"] =
        measure(runs, queries.size(), [&] { return summarize(searcher.radius(queries, radius)); });
    row["radius"]["build_ms"] = searcher.build_ms();
    structures[structure] = row;
  }

  // Agreement: everyone's distance sums; ours also the neighbour checksums (ties by index).
  json agreement = json::object();
  const std::string reference = options.structures.front();
  std::vector<std::string> searches;
  for (int k : options.ks) searches.push_back("k" + std::to_string(k));
  searches.push_back("radius");
  for (const std::string& search : searches) {
    bool agree = true;
    const json& ref = structures[reference][search];
    for (const auto& [name, row] : structures.items()) {
      agree = agree && row[search]["dist_sum"] == ref["dist_sum"] &&
              row[search]["neighbors"] == ref["neighbors"];
      if (is_ours(row["builder"]) && is_ours(structures[reference]["builder"]))
        agree = agree && row[search]["neighbor_checksum"] == ref["neighbor_checksum"];
    }
    agreement[search] = agree;
    all_agree = all_agree && agree;
  }
  out["agreement"] = agreement;
  out["mean_radius_neighbors"] = structures[reference]["radius"]["neighbors"].get<double>() /
                                 static_cast<double>(queries.size());

  // Ratios to the peers as their users call them, and the targets for ours.
  const auto has = [&](const std::string& s) { return structures.contains(s); };
  for (auto& [name, row] : structures.items()) {
    json ratios = json::object();
    for (const std::string peer : {"nanoflann", "flann"}) {
      if (!has(peer)) continue;
      ratios["build_vs_" + peer] =
          row["build_ms"].get<double>() / structures[peer]["build_ms"].get<double>();
      ratios["build_cpu_vs_" + peer] =
          row["build_cpu_ms"].get<double>() / structures[peer]["build_cpu_ms"].get<double>();
      for (const std::string& search : searches) {
        ratios[search + "_speedup_vs_" + peer] =
            row[search]["queries_per_s"].get<double>() /
            structures[peer][search]["queries_per_s"].get<double>();
        ratios[search + "_cpu_speedup_vs_" + peer] =
            row[search]["queries_per_cpu_s"].get<double>() /
            structures[peer][search]["queries_per_cpu_s"].get<double>();
      }
    }
    if (has("nanoflann") && has("flann"))
      for (const std::string& search : searches) {
        const double best = std::max(structures["nanoflann"][search]["queries_per_s"].get<double>(),
                                     structures["flann"][search]["queries_per_s"].get<double>());
        ratios[search + "_speedup_vs_faster_peer"] =
            row[search]["queries_per_s"].get<double>() / best;
        const double best_cpu =
            std::max(structures["nanoflann"][search]["queries_per_cpu_s"].get<double>(),
                     structures["flann"][search]["queries_per_cpu_s"].get<double>());
        ratios[search + "_cpu_speedup_vs_faster_peer"] =
            row[search]["queries_per_cpu_s"].get<double>() / best_cpu;
      }
    row["ratios"] = ratios;
    if (is_ours(row["builder"]) && has("nanoflann") && has("flann")) {
      json targets = json::object();
      targets["build_le_1.0x_nanoflann"] = ratios["build_vs_nanoflann"].get<double>() <= 1.0;
      for (int k : {1, 8})
        if (ratios.contains("k" + std::to_string(k) + "_speedup_vs_faster_peer"))
          targets["k" + std::to_string(k) + "_ge_1.5x"] =
              ratios["k" + std::to_string(k) + "_speedup_vs_faster_peer"].get<double>() >= 1.5;
      targets["radius_ge_1.2x"] = ratios["radius_speedup_vs_faster_peer"].get<double>() >= 1.2;
      row["targets"] = targets;
    }
  }
  out["structures"] = structures;
  return out;
}

std::string fmt_ratio(const json& ratios, const std::string& key) {
  return ratios.contains(key) ? fmt::format("{:.2f}×", ratios[key].get<double>()) : "–";
}

}  // namespace

void add_knn_bench_options(CLI::App& command, KnnBenchOptions& options) {
  command
      .add_option("--runs", options.runs,
                  "Timed runs per measurement; the median is reported (default 5, --quick 1)")
      ->check(CLI::PositiveNumber);
  command
      .add_option("--points", options.points,
                  "Surface samples per mesh (default 1000000, --quick 100000)")
      ->check(CLI::PositiveNumber);
  command
      .add_option("--queries", options.queries,
                  "Queries per mesh (default 1000000, --quick 100000)")
      ->check(CLI::PositiveNumber);
  command.add_option("--meshes", options.meshes,
                     "dragon, sibenik, cat (../shared/data), horse, dragon-vendored, or mesh files "
                     "(default: dragon sibenik cat)");
  command.add_option("--structures", options.structures,
                     "vvh, sah, median, nanoflann, flann, nanoflann+order, flann+order (the +order "
                     "peers get the queries in our Morton order)");
  command.add_option("--ks", options.ks, "k of the k-nearest searches")->check(CLI::PositiveNumber);
  command
      .add_option("--radius-fraction", options.radius_fraction,
                  "Radius of the radius search as a share of the bounding-box diagonal")
      ->check(CLI::PositiveNumber);
  command.add_option("--leaf-size", options.leaf_size, "Points per leaf of every tree")
      ->check(CLI::Range(1, 1 << 20));
  command.add_flag("--quick", options.quick,
                   "Smoke test: vendored meshes, 100k points and queries, 1 run");
  command.add_option("--threads", options.threads, "Worker threads (0 = all cores)")
      ->check(CLI::NonNegativeNumber);
  command.add_option("--seed", options.seed, "Seed of the points and queries");
  cli::add_json_options(command, options.json, "the full report");
  command.add_option("--markdown", options.markdown_path, "Write the Markdown tables to this file");
}

json run_knn_bench_report(const KnnBenchOptions& options) {
  if (options.structures.empty()) throw Error("--structures", "no structure to measure");
  for (const std::string& s : options.structures) {
    const std::string builder = s.substr(0, s.find("+order"));
    const auto names = neighbor_index_names();
    if (std::ranges::find(names, builder) == names.end() || builder == "brute")
      throw Error("--structures", "unknown structure '" + s + "'");
  }
  const ThreadLimit limit(options.threads);
  const int runs = options.runs > 0 ? options.runs : (options.quick ? 1 : 5);
  const std::size_t points = options.points ? options.points : (options.quick ? 100000 : 1000000);
  const std::size_t queries =
      options.queries ? options.queries : (options.quick ? 100000 : 1000000);
  std::vector<std::string> notes;
  const std::vector<KnnMesh> meshes = knn_meshes(options, notes);

  json report;
  report["benchmark"] = "knn";
  report["machine"] = machine_json(options.threads);
  report["settings"] = {{"points", points},
                        {"queries", queries},
                        {"runs", runs},
                        {"ks", options.ks},
                        {"radius_fraction", options.radius_fraction},
                        {"leaf_size", options.leaf_size},
                        {"seed", options.seed},
                        {"structures", options.structures},
                        {"note",
                         "build: ours in parallel, nanoflann 1.4 and FLANN 1.9 build on one "
                         "thread (they have no parallel build); queries: everyone on all "
                         "threads in fixed chunks; ours process queries in Morton order, the "
                         "plain peers in the given order, the +order peers in ours"}};
  json results = json::array();
  bool all_agree = true;
  for (const KnnMesh& mesh : meshes)
    results.push_back(run_mesh(mesh, options, points, queries, runs, all_agree));
  report["meshes"] = results;
  report["all_agree"] = all_agree;
  report["notes"] = notes;
  report["machine"]["load_average_end"] = load_average();
  return report;
}

std::string knn_markdown_report(const json& report) {
  std::string md = "# splitray bench knn\n\n";
  const json& s = report["settings"];
  md += fmt::format(
      "{} points (area-weighted surface samples) and {} surface-sample queries per mesh, leaf "
      "size {}, median of {} runs; {} on {} threads, load average {:.1f} → {:.1f}. Answers "
      "agree across all structures: {}.\n\n",
      s["points"].get<std::size_t>(), s["queries"].get<std::size_t>(), s["leaf_size"].get<int>(),
      s["runs"].get<int>(), report["machine"]["cpu"].get<std::string>(),
      report["machine"]["threads"].get<int>(),
      report["machine"]["load_average_start"].get<double>(),
      report["machine"]["load_average_end"].get<double>(),
      report["all_agree"].get<bool>() ? "yes" : "NO");
  md += s["note"].get<std::string>() + ".\n\n";
  std::vector<std::string> searches;
  for (int k : s["ks"]) searches.push_back("k" + std::to_string(k));
  searches.push_back("radius");
  for (const json& mesh : report["meshes"]) {
    md += fmt::format(
        "## {} ({} triangles; radius {:.4g} = {:.1f}% of the diagonal, {:.1f} neighbours "
        "per query)\n\n",
        mesh["mesh"].get<std::string>(), mesh["triangles"].get<std::size_t>(),
        mesh["radius"].get<double>(), 100 * s["radius_fraction"].get<double>(),
        mesh["mean_radius_neighbors"].get<double>());
    md += "| structure | build ms | × nanoflann | × FLANN |";
    for (const std::string& search : searches) md += fmt::format(" {} Mq/s | speedup |", search);
    md += "\n|---|---:|---:|---:|";
    for (std::size_t i = 0; i < searches.size(); ++i) md += "---:|---:|";
    md += "\n";
    for (const auto& [name, row] : mesh["structures"].items()) {
      const json& ratios = row["ratios"];
      md +=
          fmt::format("| {} | {:.1f} | {} | {} |", name, row["build_ms"].get<double>(),
                      fmt_ratio(ratios, "build_vs_nanoflann"), fmt_ratio(ratios, "build_vs_flann"));
      for (const std::string& search : searches)
        md += fmt::format(" {:.2f} | {} |", row[search]["queries_per_s"].get<double>() / 1e6,
                          fmt_ratio(ratios, search + "_speedup_vs_faster_peer"));
      md += "\n";
    }
    md +=
        "\nCPU time (all threads; what the work costs when the machine is shared):\n\n"
        "| structure | build CPU ms | × nanoflann |";
    for (const std::string& search : searches) md += fmt::format(" {} speedup |", search);
    md += "\n|---|---:|---:|";
    for (std::size_t i = 0; i < searches.size(); ++i) md += "---:|";
    md += "\n";
    for (const auto& [name, row] : mesh["structures"].items()) {
      const json& ratios = row["ratios"];
      md += fmt::format("| {} | {:.1f} | {} |", name, row["build_cpu_ms"].get<double>(),
                        fmt_ratio(ratios, "build_cpu_vs_nanoflann"));
      for (const std::string& search : searches)
        md += fmt::format(" {} |", fmt_ratio(ratios, search + "_cpu_speedup_vs_faster_peer"));
      md += "\n";
    }
    md += "\nspeedup = queries/s over the faster of nanoflann and FLANN (given order). ";
    md += "Agreement:";
    for (const auto& [search, agree] : mesh["agreement"].items())
      md += fmt::format(" {} {}", search, agree.get<bool>() ? "yes" : "NO");
    md += ".\n\n";
  }
  md +=
      "## Targets of issue 6 (ours against the faster peer in the given order)\n\n"
      "| mesh | structure | build ≤ 1.0× nanoflann | k=1 ≥ 1.5× | k=8 ≥ 1.5× | radius ≥ 1.2× |\n"
      "|---|---|---|---|---|---|\n";
  for (const json& mesh : report["meshes"]) {
    for (const auto& [name, row] : mesh["structures"].items()) {
      if (!row.contains("targets")) continue;
      const json& t = row["targets"];
      const json& r = row["ratios"];
      const auto cell = [&](const std::string& target, const std::string& ratio) {
        if (!t.contains(target)) return std::string("–");
        return fmt::format("{} ({:.2f}×)", t[target].get<bool>() ? "met" : "missed",
                           r[ratio].get<double>());
      };
      md += fmt::format("| {} | {} | {} | {} | {} | {} |\n", mesh["mesh"].get<std::string>(), name,
                        cell("build_le_1.0x_nanoflann", "build_vs_nanoflann"),
                        cell("k1_ge_1.5x", "k1_speedup_vs_faster_peer"),
                        cell("k8_ge_1.5x", "k8_speedup_vs_faster_peer"),
                        cell("radius_ge_1.2x", "radius_speedup_vs_faster_peer"));
    }
  }
  for (const json& note : report["notes"]) md += "\nNote: " + note.get<std::string>() + "\n";
  return md;
}

int run_knn_bench(const KnnBenchOptions& options) {
  check_output_folders({options.json.file, options.markdown_path});
  const json report = run_knn_bench_report(options);
  emit_report(options.json, options.markdown_path, report, knn_markdown_report(report));
  return report["all_agree"].get<bool>() ? 0 : 1;
}

}  // namespace splitray::bench

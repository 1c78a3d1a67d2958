#pragma once
// The nearest-neighbour benchmark (issue 6): real meshes sampled area-weighted to 1M points,
// 1M surface-sample queries, k = 1, 8, 16 and a radius search; build time and queries/s of
// our point kd-trees as ratios to nanoflann and FLANN measured in the same run on the same
// points and queries (medians of several runs), with answers checked against each other.
// Shared by `splitray bench knn` and `splitray_bench knn`.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "json_output.hpp"

namespace splitray::bench {

struct KnnBenchOptions {
  int runs = 0;                     // timed runs per measurement (median); 0 = 5 (quick: 1)
  std::size_t points = 0;           // surface samples per mesh; 0 = 1M (quick: 100k)
  std::size_t queries = 0;          // 0 = 1M (quick: 100k)
  std::vector<std::string> meshes;  // names (dragon, sibenik, cat, horse) or files; empty = default
  // Ours: vvh, sah, median. Peers: nanoflann, flann (queries in the caller's order, as their
  // users call them) and nanoflann+order, flann+order (in our Morton order, for comparison).
  std::vector<std::string> structures = {"vvh",   "median",          "nanoflann",
                                         "flann", "nanoflann+order", "flann+order"};
  std::vector<int> ks = {1, 8, 16};
  double radius_fraction = 0.005;  // radius search: this share of the bounding-box diagonal
  int leaf_size = 10;              // every tree, ours and the peers'
  bool quick = false;              // smoke test: vendored meshes, 100k points, 1 run
  int threads = 0;                 // 0 = all cores
  std::uint64_t seed = 1;
  cli::JsonOutput json;
  std::string markdown_path;
};

void add_knn_bench_options(CLI::App& command, KnnBenchOptions& options);

// Runs the benchmark (progress on stderr) and returns the JSON report.
nlohmann::ordered_json run_knn_bench_report(const KnnBenchOptions& options);

// The report's Markdown tables.
std::string knn_markdown_report(const nlohmann::ordered_json& report);

// Runs it and writes the reports atomically where asked (the Markdown goes to stdout when no
// file is given). Returns 0, or 1 if some structures disagreed on the answers.
int run_knn_bench(const KnnBenchOptions& options);

}  // namespace splitray::bench

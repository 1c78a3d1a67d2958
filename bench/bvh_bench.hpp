#pragma once
// The BVH against Embree (issue #26): on every benchmark mesh and any mesh given on the command
// line (with the camera to measure from), our `binned` and `sbvh` BVHs against Embree's medium
// and high builds (low reported too): build time with SAH cost, and Mrays/s of primary and
// diffuse rays from several viewpoints, single-ray and batched calls, at 1 and at all threads,
// medians of several runs, as ratios from the same run on the same rays; plus what a ray costs
// in our wide layout (nodes, boxes, leaves and triangle blocks per ray, bytes read), and before
// its walk (rays that cannot meet the mesh, in ours and in Embree).
#include <CLI/CLI.hpp>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "json_output.hpp"

namespace splitray::bench {

struct BvhBenchOptions {
  int runs = 0;                     // timed runs per measurement (median); 0 = 5 (quick: 1)
  std::size_t rays = 0;             // rays per kind, over all views; 0 = 2^18 (quick: 2^14)
  std::vector<std::string> meshes;  // names or files, optionally @camera; empty = all
  std::vector<int> threads;         // thread counts to measure at; empty = 1 and all cores
  int views = 4;                    // viewpoints per mesh (the camera turned in steps)
  bool quick = false;               // smoke test: the vendored meshes, 1 run, few rays
  std::uint64_t seed = 1;
  cli::JsonOutput json;
  std::string markdown_path;
};

void add_bvh_bench_options(CLI::App& command, BvhBenchOptions& options);

// Runs the benchmark (progress on stderr) and returns the JSON report.
nlohmann::ordered_json run_bvh_bench(const BvhBenchOptions& options);

// The report's Markdown tables.
std::string bvh_markdown(const nlohmann::ordered_json& report);

// Runs it and writes the reports where asked. Returns non-zero when our two BVHs disagreed on
// a hit (both are exact, so they must not).
int bvh_bench_command(const BvhBenchOptions& options);

}  // namespace splitray::bench

#pragma once
// The neural builder's evaluation (issue 7, paper 003 §6.3-6.4, Fig. 4/5): on meshes NOT used
// for training (models/README.md lists those), a top inferred by the shipped model and
// expanded by builder B against B alone, measured in the same run on the same rays/queries:
//   - kd (B = sah) and bvh (B = binned): SAH cost of the finished trees, build time and
//     Mrays/s (primary and diffuse rays, batched), hits checked identical;
//   - points (B = vvh): VVH cost, build time and k-nearest queries/s on surface samples,
//     neighbours checked identical;
//   - inference time for inputs of 10^4 .. 10^6 primitives (subsampled or replicated
//     meshes), separately from the O(N) sampling before it.
// Shared by `splitray bench neural` and `splitray_bench neural`.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "json_output.hpp"

namespace splitray::bench {

struct NeuralBenchOptions {
  int runs = 0;                      // timed runs per measurement (median); 0 = 5 (quick: 1)
  std::size_t rays = 0;              // rays per kind; 0 = 262144 (quick: 16384)
  std::size_t points = 0;            // surface samples for k-NN; 0 = 1M (quick: 50k)
  std::size_t queries = 0;           // 0 = 200k (quick: 10k)
  std::vector<int> ks = {1, 8};      // k of the k-nearest queries (paper 003 Fig. 4: k = 1)
  std::vector<std::string> meshes;   // names or files; empty = every held-out mesh present
  std::string sah_model, vvh_model;  // empty = the shipped models/sah.bin, models/vvh.bin
  std::string kd_expand = "sah", bvh_expand = "binned", point_expand = "vvh";
  bool quick = false;
  int threads = 0;
  std::uint64_t seed = 1;
  cli::JsonOutput json;
  std::string markdown_path;
};

void add_neural_bench_options(CLI::App& command, NeuralBenchOptions& options);

nlohmann::ordered_json run_neural_bench_report(const NeuralBenchOptions& options);
std::string neural_markdown_report(const nlohmann::ordered_json& report);

// Runs it and writes the reports atomically where asked (Markdown to stdout when no file is
// given). Returns 0, or 1 when a neural tree's answers differed from its expansion builder's.
int run_neural_bench(const NeuralBenchOptions& options);

}  // namespace splitray::bench

#pragma once
// Rendering an animation across processes (issue #24): `mpirun -np R splitray animate FRAMES
// --render DIR` with R ranks of one thread each on this machine (ranks beyond its cores are
// over-subscribed, and said so), against the single process (`splitray animate --render-only`,
// one thread) in the same run. Reports frames per second, frame throughput per rank, the
// measured compute, communication and assembly times, checks that every rank count writes the
// single process's images byte for byte, and projects the scaling to 8-64 nodes from the
// measured per-frame times (the model and its assumptions are in the report). Shared by
// `splitray bench dist` and `splitray_bench dist`.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "json_output.hpp"

namespace splitray::bench {

struct DistBenchOptions {
  std::string frames;                  // the sequence (default: ../shared/data's horse collapse)
  std::size_t frame_count = 8;         // frames rendered per run
  int width = 1024, height = 768;      // of the frames
  std::vector<int> ranks = {1, 2, 4};  // rank counts under mpirun
  int runs = 3;                        // runs per rank count (median wall time)
  std::string mode = "whitted";        // renderer of the frames (animate --mode)
  cli::JsonOutput json;
  std::string markdown_path;
};

void add_dist_bench_options(CLI::App& command, DistBenchOptions& options);

// Runs the benchmark (progress on stderr); returns the JSON report. Throws Error when mpirun
// or the splitray program cannot be found, a run fails, or the sequence is missing.
nlohmann::ordered_json run_dist_bench(const DistBenchOptions& options);

void dist_bench_command(const DistBenchOptions& options);

}  // namespace splitray::bench

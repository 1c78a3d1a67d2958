#pragma once
// The build-and-trace benchmark (issues 3 and 5): for every benchmark mesh, every kd, BIH and
// BVH builder and Embree low/medium/high: build time, SAH cost, cost evaluations, and Mrays/s for
// primary and diffuse rays (the same rays for everyone), medians of several runs, as ratios to
// Embree medium measured in the same run, with hit checksums compared to kd sah's. Shared by
// `splitray_bench` and `splitray bench build-trace`.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "json_output.hpp"
#include "splitray/accel/accel.hpp"

namespace splitray::bench {

struct BuildTraceOptions {
  int runs = 0;                     // timed runs per measurement (median); 0 = 5 (quick: 1)
  std::size_t rays = 0;             // rays per kind; 0 = 2^20 (quick: 2^16)
  std::vector<std::string> meshes;  // names (or files); empty = all
  std::vector<std::string> accels = {"kd", "bih", "bvh", "embree"};
  bool quick = false;  // smoke test: 2 vendored meshes, 1 run, 64k rays
  int threads = 0;     // 0 = all cores
  std::uint64_t seed = 1;
  // SAH constants of every build (and of every tree's reported SAH cost); unset = each
  // structure's own default (kd: kKdSah, the others: kSharedSah).
  std::optional<float> traversal_cost, intersection_cost;
  cli::JsonOutput json;
  std::string markdown_path;
  std::string plot_path;  // PNG of the ratios to Embree (scripts/plot_build_trace.py)
};

// Adds the options above to `command` (the same in both programs).
void add_build_trace_options(CLI::App& command, BuildTraceOptions& options);

// Runs the benchmark, progress on stderr; returns the JSON report.
nlohmann::ordered_json run_build_trace(const BuildTraceOptions& options);

// Runs it and writes the reports (atomically) where asked; prints the Markdown to stdout when
// no --markdown file is given.
void build_trace_command(const BuildTraceOptions& options);

}  // namespace splitray::bench

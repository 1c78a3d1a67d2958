#pragma once
// The kd-tree's own SAH constants (issue #20): what a node step costs against a triangle test
// in this implementation (8-byte nodes walked with a small stack, 8-wide SIMD leaf tests),
// measured rather than assumed. For every mesh, trees are built over a range of K_T (K_I
// fixed); each tree's SAH gives its expected node steps S and triangle tests T per ray, its
// rays are timed, and the times are fitted by least squares to t = a S + b T + c (c: the
// per-ray work outside the walk). a / b is the cost of a step in triangle tests: the K_T that
// fits this implementation at that K_I. Shared by `splitray_bench` and `splitray bench
// kd-costs`.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "json_output.hpp"
#include "splitray/accel/accel.hpp"

namespace splitray::bench {

struct KdCostsOptions {
  std::vector<std::string> meshes;  // names (or files); empty = all benchmark meshes present
  std::vector<float> kt = {5, 10, 15, 20, 30, 45, 60, 90};  // K_T values to build with
  float ki = kKdSah.intersection;                           // K_I, fixed
  std::string builder = "binned";  // the trees' builder (the fit is about traversal)
  std::size_t rays = 1u << 18;     // rays per kind
  int runs = 3;                    // timed passes per tree and kind (median)
  int threads = 1;                 // tracing threads (1: per-ray costs without contention)
  std::uint64_t seed = 1;
  bool quick = false;  // smoke test: the vendored horse, 3 values of K_T, 2^14 rays, 1 run
  cli::JsonOutput json;
  std::string markdown_path;
};

void add_kd_costs_options(CLI::App& command, KdCostsOptions& options);

// Runs the measurement, progress on stderr; returns the JSON report.
nlohmann::ordered_json run_kd_costs(const KdCostsOptions& options);

// Runs it and writes the reports where asked (the Markdown to stdout by default).
void kd_costs_command(const KdCostsOptions& options);

}  // namespace splitray::bench

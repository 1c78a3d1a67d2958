#pragma once
// The hybrid renderer's quality and speed report (issue 8, paper 002 §5): on a scene of more
// than 500 000 triangles with about 10% reflective pixels at 1024x768, the frame time of the
// five-pass hybrid renderer (interleaved and strictly sequential) and of the CPU Whitted
// renderer, per-pass times (paper Fig. 6), the CPU's share of Whitted's rays, the PSNR of
// hybrid against Whitted and the pixels whose shadow state differs from ray-traced shadows
// with and without boundary refinement (Fig. 8/9). Shared by `splitray bench hybrid` and
// `splitray_bench hybrid`.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "json_output.hpp"
#include "splitray/core/scene.hpp"

namespace splitray::bench {

struct HybridBenchOptions {
  std::string scene;   // mesh or JSON scene; empty = hybrid_bench_scene()
  std::string camera;  // "EX,EY,EZ,TX,TY,TZ[,FOV]"; empty = the scene's
  int width = 1024, height = 768;
  int max_depth = 5;
  int frames = 0;  // frames per throughput measurement; 0 = 8 (quick: 3)
  int runs = 0;    // Whitted renders (median); 0 = 3 (quick: 1)
  int blur_kernel = 5;
  int shadow_map_size = 2048;
  std::string accel = "kd";
  int threads = 0;
  bool quick = false;  // smoke test: 320x240, vendored meshes only
  cli::JsonOutput json;
  std::string markdown_path, plot_path;
  std::string images_dir;  // writes hybrid.png, whitted.png and shadow_errors.png there
};

// The default scene: real meshes of ../shared/data (four Stanford dragons, Sumner's cats and
// lions; the vendored dragon and horse stand in where they are absent) on a floor under one
// directional light, and a mirror sphere covering about 10% of the picture. `quick`: only
// the vendored meshes. `notes` says what stood in for what.
Scene hybrid_bench_scene(bool quick, std::vector<std::string>& notes);

void add_hybrid_bench_options(CLI::App& command, HybridBenchOptions& options);

// Runs the benchmark (progress on stderr) and returns the JSON report.
nlohmann::ordered_json run_hybrid_bench_report(const HybridBenchOptions& options);

std::string hybrid_markdown_report(const nlohmann::ordered_json& report);

// Runs it and writes the reports atomically where asked (Markdown to stdout when no file is
// given) and the plot through scripts/plot_hybrid.py. Returns 0, or 1 when a target that
// holds on every machine was missed.
int run_hybrid_bench(const HybridBenchOptions& options);

}  // namespace splitray::bench

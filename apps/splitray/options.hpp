#pragma once
// Options and helpers shared by the subcommands: structure and builder settings, the
// --camera string, loading the geometry, and printing results as tables or JSON.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "camera_option.hpp"
#include "splitray/accel/accel.hpp"
#include "splitray/core/camera.hpp"
#include "splitray/core/triangle.hpp"

namespace splitray::app {

// --accel, --builder, --threads and the BuildConfig tuning options of one subcommand. With
// `report_unused`, a warning on stderr names every option given that the chosen structure and
// builder ignore (commands that build other structures as well pass false).
struct AccelOptions {
  std::string accel = "kd";
  BuildConfig build;
};
void add_accel_options(CLI::App& command, AccelOptions& options, bool report_unused = true);

// --camera (apps/cli/camera_option.hpp), shared with the benchmarks.
using cli::add_camera_option;
using cli::CameraSpec;
using cli::parse_camera;
using cli::to_camera;

// The triangles of a mesh file, or of every instance of a JSON scene file (*.json).
struct Geometry {
  std::vector<Triangle> triangles;
  double load_ms = 0;
};
Geometry load_geometry(const std::string& path);

// Every field of AccelStats; sah_cost is null when the structure has none.
nlohmann::ordered_json stats_json(const AccelStats& stats);

// Prints "key   value" lines with the values aligned.
void print_table(const std::vector<std::pair<std::string, std::string>>& rows);
// The rows of print_table for AccelStats, in the order and with the names of stats_json.
std::vector<std::pair<std::string, std::string>> stats_rows(const AccelStats& stats);

// Error(path, ...) before any work when `path` does not end in `extension` (any case), its
// folder does not exist or it is a folder.
void check_output_path(const std::string& path, const std::string& extension);

// The worker count `--threads T` stands for (0 = all cores).
int effective_threads(int threads);

// "kd (sah)".
std::string structure_name(const AccelStats& stats);

}  // namespace splitray::app

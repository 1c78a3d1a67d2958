#include "options.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <system_error>

#include "file_options.hpp"
#include "sah_options.hpp"
#include "splitray/accel/build_options.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/output_file.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/scene.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/io/load_scene.hpp"
#include "splitray/io/mesh_io.hpp"

namespace splitray::app {

namespace {

std::string join(const std::vector<std::string>& names, const std::string& separator) {
  std::string out;
  for (const auto& name : names) out += (out.empty() ? "" : separator) + name;
  return out;
}

// "kd: sah (default), golden, binned; brute: none; ..." for the --builder help.
std::string builders_help() {
  std::vector<std::string> parts;
  for (const auto& accel : accel_names()) {
    auto builders = builder_names(accel);
    if (!builders.empty()) builders.front() += " (default)";
    if (has_neural_builder(accel)) builders.push_back("neural");
    parts.push_back(accel + ": " + join(builders, ", "));
  }
  return join(parts, "; ");
}

bool ends_with_icase(const std::string& text, const std::string& suffix) {
  if (text.size() < suffix.size()) return false;
  return std::equal(suffix.begin(), suffix.end(), text.end() - suffix.size(), [](char a, char b) {
    return std::tolower(static_cast<unsigned char>(a)) ==
           std::tolower(static_cast<unsigned char>(b));
  });
}

std::string fixed(double value, int decimals) { return fmt::format("{:.{}f}", value, decimals); }

}  // namespace

void add_accel_options(CLI::App& command, AccelOptions& options, bool report_unused) {
  if (report_unused)
    command.parse_complete_callback([&options] {
      if (!has_neural_builder(options.accel) && options.build.builder == "neural") return;
      const std::vector<std::string> names = builder_names(options.accel);
      const std::string& builder = options.build.builder;
      if (!builder.empty() && builder != "neural" &&
          std::find(names.begin(), names.end(), builder) == names.end())
        return;  // make_accel names the unknown builder
      for (const std::string& option : unused_options(options.accel, options.build))
        fmt::print(stderr, "splitray: warning: {} is ignored by --accel {} --builder {}\n", option,
                   options.accel, builder.empty() ? names.front() : builder);
    });
  command.add_option("-a,--accel", options.accel, "Acceleration structure")
      ->check(CLI::IsMember(accel_names()));
  command.add_option("-b,--builder", options.build.builder,
                     "Builder of the structure: " + builders_help());
  command
      .add_option("-t,--threads", options.build.threads,
                  "Worker threads for building and tracing (0 = all cores); results never "
                  "depend on it")
      ->check(CLI::NonNegativeNumber);
  const std::string group = "Build settings";
  cli::add_sah_options(command, options.build.traversal_cost, options.build.intersection_cost,
                       group);
  command
      .add_option("--empty-bonus", options.build.empty_bonus,
                  "SAH discount for splits that cut off empty space")
      ->check(CLI::Range(0.0, 1.0))
      ->group(group);
  command
      .add_option("--tree-depth", options.build.max_depth,
                  "Maximum tree depth (0 = automatic: 8 + 1.3 log2 N)")
      ->check(CLI::Range(0, 64))
      ->group(group);
  command
      .add_option("--leaf-size", options.build.max_leaf_prims,
                  "Nodes with this many triangles or fewer become leaves")
      ->check(CLI::Range(1, 1 << 20))
      ->group(group);
  command
      .add_option(
          "--bins", options.build.bins,
          "Bins per axis of binned builders (kd binned: in nodes of more than 64 triangles)")
      ->check(CLI::Range(2, 1 << 16))
      ->group(group);
  cli::input_files(command.add_option(
                       "--model", options.build.neural.model,
                       "--builder neural: model file (default: models/sah.bin of the source tree, "
                       "$SPLITRAY_MODEL_DIR or share/splitray/models)"))
      ->group(group);
  command
      .add_option("--expand", options.build.neural.expand,
                  "--builder neural: builder of the inferred top's leaf cells (kd: sah, golden, "
                  "binned; bvh: binned, sbvh, embree; default: the structure's default builder)")
      ->group(group);
  command
      .add_option("--top-min", options.build.neural.top_min,
                  "--builder neural: inferred-top cells of fewer triangles (estimated from the "
                  "samples) are left to the expansion builder (default 4096; 0: split down to "
                  "the model's depth)")
      ->check(CLI::Range(0, 1 << 30))
      ->group(group);
  command
      .add_flag("--greedy-top", options.build.neural.greedy_top,
                "--builder neural: the top from an exact greedy SAH sweep over the same samples "
                "instead of the network (paper 003 Fig. 3's baseline)")
      ->group(group);
}

Geometry load_geometry(const std::string& path) {
  const Timer timer;
  std::error_code error;
  if (!std::filesystem::exists(path, error)) throw Error(path, "no such file");
  if (std::filesystem::is_directory(path, error)) throw Error(path, "is a folder, not a mesh file");
  Geometry geometry;
  if (ends_with_icase(path, ".json"))
    geometry.triangles = flatten(load_scene(path)).triangles;
  else
    geometry.triangles = load_mesh(path).triangles();
  if (geometry.triangles.empty()) throw Error(path, "contains no triangles");
  geometry.load_ms = timer.ms();
  return geometry;
}

namespace {

// --builder neural only: the greedy inference time and the inferred top's depth.
void add_neural(nlohmann::ordered_json& object, const AccelStats& stats) {
  if (stats.inference_ms) object["inference_ms"] = *stats.inference_ms;
  if (stats.top_depth) object["top_depth"] = *stats.top_depth;
}

}  // namespace

nlohmann::ordered_json stats_json(const AccelStats& stats) {
  nlohmann::ordered_json object = {
      {"accel", stats.accel},
      {"builder", stats.builder},
      {"prims", stats.prims},
      {"build_ms", stats.build_ms},
      {"sah_cost", stats.sah_cost ? nlohmann::ordered_json(*stats.sah_cost) : nullptr},
      // The constants sah_cost was computed with, and its two sums (cost = K_T steps + K_I tests).
      {"sah_kt", stats.sah_cost ? nlohmann::ordered_json(stats.sah_traversal_cost) : nullptr},
      {"sah_ki", stats.sah_cost ? nlohmann::ordered_json(stats.sah_intersection_cost) : nullptr},
      {"sah_node_steps",
       stats.sah_node_steps ? nlohmann::ordered_json(*stats.sah_node_steps) : nullptr},
      {"sah_triangle_tests",
       stats.sah_triangle_tests ? nlohmann::ordered_json(*stats.sah_triangle_tests) : nullptr},
      {"nodes", stats.nodes},
      {"leaves", stats.leaves},
      {"empty_leaves", stats.empty_leaves},
      {"max_depth", stats.max_depth},
      {"mean_leaf_depth", stats.mean_leaf_depth},
      {"mean_leaf_prims", stats.mean_leaf_prims},
      {"prim_refs", stats.prim_refs},
      {"bytes", stats.bytes},
      {"cost_evals", stats.cost_evals},
  };
  add_neural(object, stats);
  return object;
}

std::vector<std::pair<std::string, std::string>> stats_rows(const AccelStats& stats) {
  const double evals_per_node = stats.nodes > stats.leaves ? static_cast<double>(stats.cost_evals) /
                                                                 (stats.nodes - stats.leaves)
                                                           : 0.0;
  std::vector<std::pair<std::string, std::string>> rows = {
      {"accel", stats.accel},
      {"builder", stats.builder},
      {"prims", std::to_string(stats.prims)},
      {"build_ms", fixed(stats.build_ms, 2)},
      {"sah_cost", stats.sah_cost
                       ? fmt::format("{:.3f} (K_T = {}, K_I = {})", *stats.sah_cost,
                                     stats.sah_traversal_cost, stats.sah_intersection_cost)
                       : "n/a"},
      {"nodes", std::to_string(stats.nodes)},
      {"leaves", std::to_string(stats.leaves)},
      {"empty_leaves", std::to_string(stats.empty_leaves)},
      {"max_depth", std::to_string(stats.max_depth)},
      {"mean_leaf_depth", fixed(stats.mean_leaf_depth, 2)},
      {"mean_leaf_prims", fixed(stats.mean_leaf_prims, 2)},
      {"prim_refs", std::to_string(stats.prim_refs)},
      {"bytes", fmt::format("{} ({:.2f} MiB)", stats.bytes, stats.bytes / (1024.0 * 1024.0))},
      {"cost_evals",
       fmt::format("{} ({:.1f} per interior node)", stats.cost_evals, evals_per_node)},
  };
  if (stats.inference_ms) rows.emplace_back("inference_ms", fixed(*stats.inference_ms, 3));
  if (stats.top_depth) rows.emplace_back("top_depth", std::to_string(*stats.top_depth));
  return rows;
}

void print_table(const std::vector<std::pair<std::string, std::string>>& rows) {
  std::size_t width = 0;
  for (const auto& row : rows) width = std::max(width, row.first.size());
  for (const auto& [key, value] : rows) fmt::print("{:<{}}  {}\n", key, width, value);
  std::fflush(stdout);
}

void check_output_path(const std::string& path, const std::string& extension) {
  if (!ends_with_icase(path, extension))
    throw Error(path, "the output must be a " + extension + " file");
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  std::error_code error;
  if (!parent.empty() && !std::filesystem::is_directory(parent, error))
    throw Error(path, "cannot write: folder " + parent.string() + " does not exist");
  if (std::filesystem::is_directory(path, error)) throw Error(path, "cannot write: it is a folder");
  check_output_file(path);
}

int effective_threads(int threads) { return threads > 0 ? threads : hardware_threads(); }

std::string structure_name(const AccelStats& stats) {
  return stats.builder.empty() || stats.builder == "none"
             ? stats.accel
             : stats.accel + " (" + stats.builder + ")";
}

}  // namespace splitray::app

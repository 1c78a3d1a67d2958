// splitray build MESH --accel A: builds one structure and prints its statistics.
#include <fmt/core.h>

#include <memory>

#include "commands.hpp"
#include "file_options.hpp"
#include "json_output.hpp"
#include "options.hpp"

namespace splitray::app {

namespace {

struct BuildCommand {
  std::string mesh;
  AccelOptions accel;
  cli::JsonOutput json;
};

void run(const BuildCommand& command) {
  const Geometry geometry = load_geometry(command.mesh);
  const auto accel = make_accel(command.accel.accel, geometry.triangles, command.accel.build);
  const AccelStats& stats = accel->stats();
  const int threads = effective_threads(command.accel.build.threads);
  if (command.json.wanted()) {
    nlohmann::ordered_json object = stats_json(stats);
    object["mesh"] = command.mesh;
    object["load_ms"] = geometry.load_ms;
    object["threads"] = threads;
    cli::emit_json(command.json, object);
    if (command.json.print) return;
  }
  fmt::print("splitray build: {} on {}\n", structure_name(stats), command.mesh);
  auto rows = stats_rows(stats);
  rows.emplace_back("load_ms", fmt::format("{:.2f}", geometry.load_ms));
  rows.emplace_back("threads", std::to_string(threads));
  print_table(rows);
}

}  // namespace

void add_build_command(CLI::App& app) {
  auto command = std::make_shared<BuildCommand>();
  CLI::App* sub =
      app.add_subcommand("build", "Build a structure over a mesh and print its statistics");
  sub->add_option("MESH", command->mesh,
                  "Mesh file (any format of render; also *.gz) or JSON scene")
      ->required();
  add_accel_options(*sub, command->accel);
  cli::add_json_options(
      *sub, command->json,
      "prims, build_ms, sah_cost (null if none), nodes, leaves, "
      "empty_leaves, max_depth, mean_leaf_depth, mean_leaf_prims, prim_refs, bytes, "
      "cost_evals, accel, builder, mesh, load_ms, threads; with --builder neural also "
      "inference_ms and top_depth (sah_cost is computed from the finished tree the same "
      "way for every builder)");
  cli::input_files(sub->get_option("MESH"));
  sub->callback([command] { run(*command); });
}

}  // namespace splitray::app

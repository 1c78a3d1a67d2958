#include "build_trace.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <memory>
#include <optional>

#include "bench_meshes.hpp"
#include "bench_report.hpp"
#include "machine.hpp"
#include "sah_options.hpp"
#include "splitray/accel/accel.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/image.hpp"
#include "splitray/core/mesh.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/io/plot_script.hpp"
#include "splitray/render/ray_sets.hpp"
#include "trace_measure.hpp"

namespace splitray::bench {

namespace {

using Json = nlohmann::ordered_json;

constexpr int kDefaultRuns = 5, kQuickRuns = 1;
constexpr std::size_t kDefaultRays = 1u << 20, kQuickRays = 1u << 16;

struct Structure {
  std::string accel, builder;
  std::string label() const { return accel + " " + builder; }
};

// Every builder of the wanted structures: the checksum reference first (kd sah, the exact
// builder), the yardstick Embree last (low, medium, high).
std::vector<Structure> structures(const std::vector<std::string>& accels) {
  std::vector<Structure> list;
  for (const std::string& accel : accels) {
    std::vector<std::string> builders = builder_names(accel);  // throws on an unknown name
    if (accel == "embree") builders = {"low", "medium", "high"};
    std::stable_partition(builders.begin(), builders.end(),
                          [](const std::string& b) { return b == "sah"; });
    for (const std::string& b : builders) list.push_back({accel, b});
  }
  std::stable_partition(list.begin(), list.end(),
                        [](const Structure& s) { return s.accel != "embree"; });
  return list;
}

struct RaySet {
  std::string kind;
  std::vector<Ray> rays;
  std::vector<Hit> reference;  // kd sah's hits, once measured
};

// One structure on one mesh: builds `runs` times, then traces every ray set.
Json measure(const Structure& s, std::span<const Triangle> triangles, std::vector<RaySet>& sets,
             const BuildTraceOptions& options, int runs, bool is_reference) {
  BuildConfig config;
  config.builder = s.builder;
  config.threads = options.threads;
  config.traversal_cost = options.traversal_cost;
  config.intersection_cost = options.intersection_cost;
  Json row{{"accel", s.accel}, {"builder", s.builder}};
  std::unique_ptr<Accel> accel;
  std::vector<double> build_ms, wall_ms;
  for (int r = 0; r < runs; ++r) {
    accel.reset();  // never two trees alive: memory and caches as in a single build
    Timer timer;
    accel = make_accel(s.accel, triangles, config);
    wall_ms.push_back(timer.ms());
    build_ms.push_back(accel->stats().build_ms);
  }
  const AccelStats& stats = accel->stats();
  row["build_ms"] = median(build_ms);
  row["build_ms_runs"] = build_ms;
  row["make_accel_ms"] = median(wall_ms);  // including what the structure leaves out of build_ms
  row["sah_cost"] = stats.sah_cost ? Json(*stats.sah_cost) : Json(nullptr);
  row["sah_kt"] = stats.sah_traversal_cost;  // the constants sah_cost was computed with
  row["sah_ki"] = stats.sah_intersection_cost;
  row["cost_evals"] = stats.cost_evals;
  row["nodes"] = stats.nodes;
  row["leaves"] = stats.leaves;
  row["max_depth"] = stats.max_depth;
  row["prim_refs"] = stats.prim_refs;
  row["bytes"] = stats.bytes;

  Json trace = Json::object();
  for (RaySet& set : sets) {
    std::vector<Hit> hits(set.rays.size()), single_hits(set.rays.size());
    Json t;
    t["batched"] = throughput(set.rays.size(), runs, [&] { accel->intersect(set.rays, hits); });
    // Accel's own loop of single-ray calls (for Embree: rtcIntersect1 on every core).
    t["single"] =
        throughput(set.rays.size(), runs, [&] { accel->intersect_each(set.rays, single_hits); });
    const Checksum c = checksum(hits);
    t["hits"] = c.hits;
    t["id_checksum"] = c.id_checksum;
    t["single_equals_batched"] = differing(hits, single_hits) == 0;
    if (is_reference) set.reference = hits;
    if (!set.reference.empty()) {
      const Checksum ref = checksum(set.reference);
      t["matches_reference"] = c.hits == ref.hits && c.id_checksum == ref.id_checksum;
      t["rays_differing_from_reference"] = differing(hits, set.reference);
    }
    trace[set.kind] = t;
  }
  row["trace"] = trace;
  return row;
}

// Ratios of every row to Embree medium's, measured on the same mesh in the same run.
void add_ratios(Json& rows) {
  const Json* yardstick = nullptr;
  for (const Json& row : rows)
    if (row.value("accel", "") == "embree" && row.value("builder", "") == "medium" &&
        !row.contains("error"))
      yardstick = &row;
  if (!yardstick) return;
  const Json e = *yardstick;
  for (Json& row : rows) {
    if (row.contains("error")) continue;
    row["build_ratio"] = row["build_ms"].get<double>() / e["build_ms"].get<double>();
    for (auto& [kind, t] : row["trace"].items()) {
      if (!e["trace"].contains(kind)) continue;
      const Json& et = e["trace"][kind];
      for (const char* mode : {"batched", "single"})
        t[mode]["ratio"] =
            t[mode]["mrays_per_s"].get<double>() / et[mode]["mrays_per_s"].get<double>();
      // The target compares with Embree's rtcIntersect1.
      t["batched"]["ratio_to_embree_single"] =
          t["batched"]["mrays_per_s"].get<double>() / et["single"]["mrays_per_s"].get<double>();
    }
  }
}

}  // namespace

void add_build_trace_options(CLI::App& command, BuildTraceOptions& options) {
  command
      .add_option("--runs", options.runs,
                  "Timed runs per measurement; the median is reported (default 5, --quick 1)")
      ->check(CLI::PositiveNumber);
  command.add_option("--rays", options.rays, "Rays per kind (default 1048576, --quick 65536)")
      ->check(CLI::PositiveNumber);
  command.add_option("--meshes", options.meshes,
                     "Benchmark meshes by name (horse, dragon, sibenik, cornell_box, ...) or mesh "
                     "files, each optionally with @EX,EY,EZ,TX,TY,TZ[,FOV], the camera to measure "
                     "from; default: all present");
  command.add_flag("--quick", options.quick,
                   "Smoke test: the two vendored meshes, 1 run, 65536 rays");
  command.add_option(
      "--accels", options.accels,
      "Structures to measure, each with all its builders (default: kd bih bvh embree)");
  command.add_option("--threads", options.threads, "Worker threads (0 = all cores)")
      ->check(CLI::NonNegativeNumber);
  command.add_option("--seed", options.seed, "Seed of the ray sets");
  cli::add_sah_options(command, options.traversal_cost, options.intersection_cost);
  cli::add_json_options(command, options.json, "the full report");
  command.add_option("--markdown", options.markdown_path,
                     "Write the Markdown tables to this file (default: print them)");
  command.add_option("--plot", options.plot_path,
                     "Draw build time and Mrays/s of every structure as ratios to Embree, per "
                     "mesh, to this PNG (scripts/plot_build_trace.py, /usr/bin/python3)");
}

Json run_build_trace(const BuildTraceOptions& options) {
  const int runs = options.runs > 0 ? options.runs : (options.quick ? kQuickRuns : kDefaultRuns);
  const std::size_t ray_count =
      options.rays > 0 ? options.rays : (options.quick ? kQuickRays : kDefaultRays);
  const ThreadLimit limit(options.threads);

  std::vector<std::string> notes;
  const std::vector<BenchMesh> meshes = select_meshes(
      benchmark_meshes(options.quick && options.meshes.empty(), notes), options.meshes);
  const std::vector<Structure> list = structures(options.accels);

  Json report;
  report["benchmark"] = "build-trace";
  report["machine"] = machine_json(options.threads);
  report["settings"] = {
      {"runs", runs},
      {"rays_per_kind", ray_count},
      {"seed", options.seed},
      // null = each structure's default, below (every row has its own
      // sah_kt, sah_ki)
      {"traversal_cost", options.traversal_cost ? Json(*options.traversal_cost) : Json(nullptr)},
      {"intersection_cost",
       options.intersection_cost ? Json(*options.intersection_cost) : Json(nullptr)},
      {"sah_defaults",
       {{"kd", {kKdSah.traversal, kKdSah.intersection}},
        {"others", {kSharedSah.traversal, kSharedSah.intersection}}}},
      {"kinds", {"primary", "diffuse"}},
      {"ratios_to", "embree medium (same mesh, same run, same rays)"},
      {"checksum_reference", "kd sah"},
      {"quick", options.quick}};
  Json mesh_reports = Json::array();
  for (std::size_t m = 0; m < meshes.size(); ++m) {
    const BenchMesh& mesh = meshes[m];
    Json mr{{"name", mesh.name}, {"path", report_path(mesh.path)}};
    std::vector<Triangle> triangles;
    try {
      Timer timer;
      triangles = load_mesh(mesh.path).triangles();
      mr["load_ms"] = timer.ms();
    } catch (const Error& e) {
      notes.push_back(mesh.name + ": " + e.what());
      fmt::print(stderr, "[{}/{}] {}: cannot load: {}\n", m + 1, meshes.size(), mesh.name,
                 e.what());
      continue;
    }
    mr["triangles"] = triangles.size();
    const Camera camera = mesh.camera ? *mesh.camera : fit_camera(triangles);
    mr["camera"] = camera_json(camera, mesh.view);
    fmt::print(stderr, "[{}/{}] {} ({} triangles, {})\n", m + 1, meshes.size(), mesh.name,
               triangles.size(), mesh.view);

    std::vector<RaySet> sets;
    for (const RayKind kind : {RayKind::primary, RayKind::diffuse}) {
      const std::string name = kind == RayKind::primary ? "primary" : "diffuse";
      try {
        sets.push_back({name, make_rays(triangles, kind, options.seed, ray_count, camera), {}});
      } catch (const Error& e) {
        notes.push_back(mesh.name + ": no " + name + " rays: " + e.what());
        fmt::print(stderr, "  no {} rays: {}\n", name, e.what());
      }
    }

    Json rows = Json::array();
    for (const Structure& s : list) {
      const bool is_reference = s.accel == "kd" && s.builder == "sah";
      try {
        Json row = measure(s, triangles, sets, options, runs, is_reference);
        std::string line =
            fmt::format("  {:<14} build {:9.2f} ms", s.label(), row["build_ms"].get<double>());
        for (auto& [kind, t] : row["trace"].items())
          line += fmt::format("  {} {:6.2f}/{:6.2f} Mrays/s{}", kind,
                              t["single"]["mrays_per_s"].get<double>(),
                              t["batched"]["mrays_per_s"].get<double>(),
                              t.value("matches_reference", true) ? "" : " (differs from kd sah)");
        fmt::print(stderr, "{}\n", line);
        rows.push_back(std::move(row));
      } catch (const Error& e) {
        fmt::print(stderr, "  {:<14} failed: {}\n", s.label(), e.what());
        rows.push_back(Json{{"accel", s.accel}, {"builder", s.builder}, {"error", e.what()}});
      }
    }
    add_ratios(rows);
    mr["results"] = rows;
    mesh_reports.push_back(std::move(mr));
  }
  report["meshes"] = mesh_reports;
  report["machine"]["load_average_end"] = load_average();
  report["notes"] = notes;
  return report;
}

void build_trace_command(const BuildTraceOptions& options) {
  // Fail on an output folder that does not exist before the long run, not after it.
  check_output_folders({options.json.file, options.markdown_path, options.plot_path});
  const Json report = run_build_trace(options);
  emit_report(options.json, options.markdown_path, report, markdown_report(report));
  if (!options.plot_path.empty()) {
    const ReportFile data(options.json, report, "splitray-build-trace");
    run_plot_script("plot_build_trace.py", options.plot_path, data.path);
  }
  for (const std::string& path : {options.json.file, options.markdown_path, options.plot_path})
    if (!path.empty()) fmt::print(stderr, "wrote {}\n", path);
}

}  // namespace splitray::bench

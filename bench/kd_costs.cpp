#include "kd_costs.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <optional>

#include "bench_meshes.hpp"
#include "bench_report.hpp"
#include "machine.hpp"
#include "splitray/accel/accel.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/mesh.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/render/ray_sets.hpp"

namespace splitray::bench {

namespace {

using Json = nlohmann::ordered_json;

constexpr std::array kKinds = {RayKind::primary, RayKind::diffuse};
const char* kind_name(RayKind kind) { return kind == RayKind::primary ? "primary" : "diffuse"; }

// Median ns per ray of `runs` timed batched passes, after one warm-up pass.
double ns_per_ray(const Accel& accel, std::span<const Ray> rays, int runs) {
  std::vector<Hit> hits(rays.size());
  accel.intersect(rays, hits);
  std::vector<double> ns;
  for (int r = 0; r < runs; ++r) {
    Timer timer;
    accel.intersect(rays, hits);
    ns.push_back(timer.ms() * 1e6 / static_cast<double>(rays.size()));
  }
  return median(ns);
}

struct Sample {
  double steps, tests, ns;
};

// Least squares t = a S + b T + c over the samples (normal equations, Gaussian elimination
// with partial pivoting); none when the system is singular (too few distinct trees).
std::optional<std::array<double, 3>> fit(const std::vector<Sample>& samples) {
  double m[3][4] = {};
  for (const Sample& s : samples) {
    const double x[3] = {s.steps, s.tests, 1.0};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) m[i][j] += x[i] * x[j];
      m[i][3] += x[i] * s.ns;
    }
  }
  for (int col = 0; col < 3; ++col) {
    int pivot = col;
    for (int row = col + 1; row < 3; ++row)
      if (std::abs(m[row][col]) > std::abs(m[pivot][col])) pivot = row;
    if (std::abs(m[pivot][col]) < 1e-12 * (std::abs(m[0][0]) + 1)) return std::nullopt;
    std::swap(m[col], m[pivot]);
    for (int row = 0; row < 3; ++row) {
      if (row == col) continue;
      const double f = m[row][col] / m[col][col];
      for (int k = col; k < 4; ++k) m[row][k] -= f * m[col][k];
    }
  }
  return std::array<double, 3>{m[0][3] / m[0][0], m[1][3] / m[1][1], m[2][3] / m[2][2]};
}

Json fit_json(const std::vector<Sample>& samples, float ki) {
  const std::optional<std::array<double, 3>> f = fit(samples);
  if (!f) return Json{{"error", "singular: the trees do not differ enough"}};
  const auto [a, b, c] = *f;
  Json j{{"ns_per_step", a}, {"ns_per_test", b}, {"ns_per_ray_fixed", c}};
  // K_T / K_I = (cost of a step) / (cost of a test); meaningless unless both are positive.
  j["implied_kt"] = a > 0 && b > 0 ? Json(ki * a / b) : Json(nullptr);
  return j;
}

double geometric_mean(const std::vector<double>& values) {
  double log_sum = 0;
  for (const double v : values) log_sum += std::log(v);
  return std::exp(log_sum / static_cast<double>(values.size()));
}

// Per K_T, the geometric mean over meshes of build and trace time relative to the tree built
// at `reference_kt` (the shared default) on the same mesh.
Json relative_summary(const Json& meshes, const std::vector<float>& kt, float reference_kt) {
  Json rows = Json::array();
  for (const float k : kt) {
    std::vector<double> build;
    std::array<std::vector<double>, kKinds.size()> trace;
    for (const Json& mesh : meshes) {
      const Json* ref = nullptr;
      const Json* row = nullptr;
      for (const Json& r : mesh["trees"]) {
        if (r["kt"].get<float>() == reference_kt) ref = &r;
        if (r["kt"].get<float>() == k) row = &r;
      }
      if (!ref || !row) continue;
      build.push_back((*row)["build_ms"].get<double>() / (*ref)["build_ms"].get<double>());
      for (std::size_t i = 0; i < kKinds.size(); ++i) {
        const char* name = kind_name(kKinds[i]);
        if (row->contains(name) && ref->contains(name))
          trace[i].push_back((*row)[name].get<double>() / (*ref)[name].get<double>());
      }
    }
    if (build.empty()) continue;
    Json r{{"kt", k}, {"build_time", geometric_mean(build)}};
    for (std::size_t i = 0; i < kKinds.size(); ++i)
      if (!trace[i].empty())
        r[std::string(kind_name(kKinds[i])) + "_time"] = geometric_mean(trace[i]);
    rows.push_back(std::move(r));
  }
  return rows;
}

std::string markdown(const Json& report) {
  const Json& s = report["settings"];
  std::string md = fmt::format(
      "# kd-tree cost constants (`splitray bench kd-costs`)\n\n{}, {} thread(s); builder `{}`, "
      "K_I = {}, {} rays per kind, median of {} runs.\n\n",
      report["machine"].value("cpu", "unknown CPU"), s["threads"].get<int>(),
      s["builder"].get<std::string>(), s["ki"].get<float>(), s["rays_per_kind"].get<std::size_t>(),
      s["runs"].get<int>());
  if (!report["median_implied_kt"].is_null())
    md += fmt::format(
        "**Median implied K_T over meshes and ray kinds: {:.1f}** at K_I = {} (the kd-tree's "
        "default is K_T = {}, K_I = {}, chosen from this fit; BIH and BVH build at {} / {}).\n\n",
        report["median_implied_kt"].get<double>(), s["ki"].get<float>(), kKdSah.traversal,
        kKdSah.intersection, kSharedSah.traversal, kSharedSah.intersection);
  md += fmt::format(
      "## Relative to K_T = {} (geometric mean over meshes; < 1 is faster)\n\n"
      "| K_T | build time | primary trace | diffuse trace |\n|---:|---:|---:|---:|\n",
      s["reference_kt"].get<float>());
  auto cell = [](const Json& row, const char* key) {
    return row.contains(key) ? fmt::format("{:.3f}", row[key].get<double>()) : std::string("-");
  };
  for (const Json& r : report["relative"])
    md += fmt::format("| {} | {} | {} | {} |\n", r["kt"].get<float>(), cell(r, "build_time"),
                      cell(r, "primary_time"), cell(r, "diffuse_time"));
  md +=
      "\n## Fitted costs (t = a S + b T + c per ray; implied K_T = K_I a / b)\n\n"
      "| mesh | triangles | rays | a ns/step | b ns/test | c ns | implied K_T | fastest K_T |\n"
      "|---|---:|---|---:|---:|---:|---:|---:|\n";
  for (const Json& m : report["meshes"]) {
    for (const auto& [kind, f] : m["fits"].items()) {
      if (f.contains("error")) {
        md += fmt::format("| {} | {} | {} | {} |||||\n", m["name"].get<std::string>(),
                          m["triangles"].get<std::size_t>(), kind, f["error"].get<std::string>());
        continue;
      }
      md += fmt::format(
          "| {} | {} | {} | {:.2f} | {:.2f} | {:.1f} | {} | {} |\n", m["name"].get<std::string>(),
          m["triangles"].get<std::size_t>(), kind, f["ns_per_step"].get<double>(),
          f["ns_per_test"].get<double>(), f["ns_per_ray_fixed"].get<double>(),
          f["implied_kt"].is_null() ? std::string("-")
                                    : fmt::format("{:.1f}", f["implied_kt"].get<double>()),
          m["fastest_kt"][kind].get<float>());
    }
  }
  md +=
      "\n## Trees\n\n| mesh | K_T | nodes/triangle | S (steps/ray) | T (tests/ray) | build ms | "
      "primary ns/ray | diffuse ns/ray |\n|---|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const Json& m : report["meshes"])
    for (const Json& t : m["trees"])
      md += fmt::format(
          "| {} | {} | {:.2f} | {:.1f} | {:.2f} | {:.1f} | {} | {} |\n",
          m["name"].get<std::string>(), t["kt"].get<float>(), t["nodes_per_triangle"].get<double>(),
          t["steps"].get<double>(), t["tests"].get<double>(), t["build_ms"].get<double>(),
          t.contains("primary") ? fmt::format("{:.1f}", t["primary"].get<double>()) : "-",
          t.contains("diffuse") ? fmt::format("{:.1f}", t["diffuse"].get<double>()) : "-");
  if (!report["notes"].empty()) {
    md += "\nNotes:\n";
    for (const Json& n : report["notes"]) md += "- " + n.get<std::string>() + "\n";
  }
  return md;
}

}  // namespace

void add_kd_costs_options(CLI::App& command, KdCostsOptions& options) {
  command.add_option("--meshes", options.meshes,
                     "Benchmark meshes by name or mesh files (default: all present)");
  command.add_option("--kt", options.kt, "K_T values to build with")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command.add_option("--ki", options.ki, "K_I of every build")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command.add_option("--builder", options.builder, "kd builder of the trees")
      ->capture_default_str();
  command.add_option("--rays", options.rays, "Rays per kind")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command.add_option("--runs", options.runs, "Timed passes per tree and kind (median)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command.add_option("--threads", options.threads, "Build and trace threads (0 = all cores)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  command.add_option("--seed", options.seed, "Seed of the ray sets");
  command.add_flag("--quick", options.quick,
                   "Smoke test: the vendored meshes, K_T 5 15 60, 16384 rays, 1 run");
  cli::add_json_options(command, options.json, "the full report");
  command.add_option("--markdown", options.markdown_path,
                     "Write the Markdown tables to this file (default: print them)");
}

Json run_kd_costs(const KdCostsOptions& options) {
  KdCostsOptions o = options;
  if (o.quick) {
    o.kt = {5, 15, 60};
    o.rays = std::min<std::size_t>(o.rays, 1u << 14);
    o.runs = 1;
  }
  std::sort(o.kt.begin(), o.kt.end());
  o.kt.erase(std::unique(o.kt.begin(), o.kt.end()), o.kt.end());
  const float reference_kt = kSharedTraversalCost;  // the constants before #20
  if (std::find(o.kt.begin(), o.kt.end(), reference_kt) == o.kt.end()) {
    o.kt.push_back(reference_kt);  // the relative table needs the shared default
    std::sort(o.kt.begin(), o.kt.end());
  }
  const ThreadLimit limit(o.threads);

  std::vector<std::string> notes;
  const std::vector<BenchMesh> meshes =
      select_meshes(benchmark_meshes(o.quick && o.meshes.empty(), notes), o.meshes);

  Json report;
  report["benchmark"] = "kd-costs";
  report["machine"] = machine_json(o.threads);
  report["settings"] = {{"builder", o.builder},
                        {"kt", o.kt},
                        {"ki", o.ki},
                        {"reference_kt", reference_kt},
                        {"rays_per_kind", o.rays},
                        {"runs", o.runs},
                        {"threads", o.threads},
                        {"seed", o.seed},
                        {"quick", o.quick},
                        {"times", "batched intersect, ns per ray"}};
  Json mesh_reports = Json::array();
  for (std::size_t m = 0; m < meshes.size(); ++m) {
    const BenchMesh& mesh = meshes[m];
    std::vector<Triangle> triangles;
    try {
      triangles = load_mesh(mesh.path).triangles();
    } catch (const Error& e) {
      notes.push_back(mesh.name + ": " + e.what());
      continue;
    }
    const Camera camera = mesh.camera ? *mesh.camera : fit_camera(triangles);
    fmt::print(stderr, "[{}/{}] {} ({} triangles)\n", m + 1, meshes.size(), mesh.name,
               triangles.size());
    std::vector<std::pair<RayKind, std::vector<Ray>>> sets;
    for (const RayKind kind : kKinds) {
      try {
        sets.emplace_back(kind, make_rays(triangles, kind, o.seed, o.rays, camera));
      } catch (const Error& e) {
        notes.push_back(mesh.name + ": no " + kind_name(kind) + " rays: " + e.what());
      }
    }
    Json trees = Json::array();
    std::array<std::vector<Sample>, kKinds.size()> samples;
    for (const float kt : o.kt) {
      BuildConfig config;
      config.builder = o.builder;
      config.traversal_cost = kt;
      config.intersection_cost = o.ki;
      config.threads = o.threads;
      const std::unique_ptr<Accel> accel = make_accel("kd", triangles, config);
      const AccelStats& stats = accel->stats();
      Json t{{"kt", kt},
             {"nodes", stats.nodes},
             {"nodes_per_triangle",
              static_cast<double>(stats.nodes) / static_cast<double>(triangles.size())},
             {"steps", stats.sah_node_steps.value_or(0)},
             {"tests", stats.sah_triangle_tests.value_or(0)},
             {"build_ms", stats.build_ms}};
      std::string line = fmt::format("  K_T {:5}: {:5.2f} nodes/tri, build {:8.1f} ms", kt,
                                     t["nodes_per_triangle"].get<double>(), stats.build_ms);
      for (const auto& [kind, rays] : sets) {
        const double ns = ns_per_ray(*accel, rays, o.runs);
        t[kind_name(kind)] = ns;
        samples[kind == RayKind::primary ? 0 : 1].push_back(
            {t["steps"].get<double>(), t["tests"].get<double>(), ns});
        line += fmt::format(", {} {:6.1f} ns/ray", kind_name(kind), ns);
      }
      fmt::print(stderr, "{}\n", line);
      trees.push_back(std::move(t));
    }
    Json fits = Json::object(), fastest = Json::object();
    for (std::size_t i = 0; i < kKinds.size(); ++i) {
      if (samples[i].empty()) continue;
      const char* name = kind_name(kKinds[i]);
      fits[name] = fit_json(samples[i], o.ki);
      const auto best =
          std::min_element(trees.begin(), trees.end(), [&](const Json& a, const Json& b) {
            return a[name].get<double>() < b[name].get<double>();
          });
      fastest[name] = (*best)["kt"];
    }
    mesh_reports.push_back(Json{{"name", mesh.name},
                                {"path", mesh.path},
                                {"triangles", triangles.size()},
                                {"trees", trees},
                                {"fits", fits},
                                {"fastest_kt", fastest}});
  }
  report["meshes"] = mesh_reports;
  report["relative"] = relative_summary(mesh_reports, o.kt, reference_kt);
  // The constant to choose: the median over meshes and ray kinds of the fitted K_T (robust to
  // the few meshes too small for a fit to mean anything).
  std::vector<double> implied;
  for (const Json& m : mesh_reports)
    for (const auto& [kind, f] : m["fits"].items())
      if (f.contains("implied_kt") && !f["implied_kt"].is_null())
        implied.push_back(f["implied_kt"].get<double>());
  report["median_implied_kt"] = implied.empty() ? Json(nullptr) : Json(median(implied));
  report["machine"]["load_average_end"] = load_average();
  report["notes"] = notes;
  return report;
}

void kd_costs_command(const KdCostsOptions& options) {
  check_output_folders({options.json.file, options.markdown_path});
  const Json report = run_kd_costs(options);
  emit_report(options.json, options.markdown_path, report, markdown(report));
}

}  // namespace splitray::bench

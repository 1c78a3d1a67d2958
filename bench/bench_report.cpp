#include "bench_report.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <optional>

#include "splitray/core/errors.hpp"
#include "splitray/core/image.hpp"

namespace splitray::bench {

namespace {

using Json = nlohmann::ordered_json;

std::string number(const Json& value, const char* format = "{:.2f}") {
  if (value.is_null()) return "–";
  if (value.is_number_float()) return fmt::format(fmt::runtime(format), value.get<double>());
  if (value.is_number()) return fmt::format("{}", value.get<std::uint64_t>());
  return value.dump();
}

std::string with_ratio(const Json& measurement) {
  std::string text = number(measurement.value("mrays_per_s", Json(nullptr)));
  if (measurement.contains("ratio"))
    text += fmt::format(" ({:.2f}×)", measurement["ratio"].get<double>());
  return text;
}

std::string mib(std::uint64_t bytes) {
  return bytes == 0 ? "–"
                    : fmt::format("{:.1f} MiB", static_cast<double>(bytes) / (1024.0 * 1024.0));
}

std::string check(const Json& row) {
  if (row["accel"] == "kd" && row["builder"] == "sah") return "reference";
  std::string text;
  for (const auto& [kind, t] : row["trace"].items()) {
    if (!t.contains("matches_reference")) continue;
    if (!text.empty()) text += "; ";
    text += t["matches_reference"].get<bool>()
                ? kind + " ✓"
                : fmt::format("{} ✗ {} rays differ", kind,
                              t["rays_differing_from_reference"].get<std::uint64_t>());
    if (!t.value("single_equals_batched", true)) text += " (1-ray ≠ batched)";
  }
  return text.empty() ? "–" : text;
}

const Json* find_row(const Json& rows, const std::string& accel, const std::string& builder) {
  for (const Json& row : rows)
    if (row["accel"] == accel && row["builder"] == builder && !row.contains("error")) return &row;
  return nullptr;
}

// "4.2× ✓" against a lower (at_least) or upper bound.
std::string target(std::optional<double> value, double bound, bool at_least) {
  if (!value) return "–";
  const bool met = at_least ? *value >= bound : *value <= bound;
  return fmt::format("{:.2f}{}", *value, met ? " ✓" : " ✗");
}

std::optional<double> ratio(const Json* a, const Json* b, const char* key) {
  if (!a || !b || (*a)[key].is_null() || (*b)[key].is_null()) return std::nullopt;
  return (*a)[key].get<double>() / (*b)[key].get<double>();
}

std::optional<double> trace_target(const Json* row, const char* kind) {
  if (!row || !(*row)["trace"].contains(kind)) return std::nullopt;
  const Json& batched = (*row)["trace"][kind]["batched"];
  if (!batched.contains("ratio_to_embree_single")) return std::nullopt;
  return batched["ratio_to_embree_single"].get<double>();
}

// Single-ray throughput of `row` over `peer`'s (rtcIntersect1 for Embree) on rays `kind`.
std::optional<double> single_ratio(const Json* row, const Json* peer, const char* kind) {
  if (!row || !peer || !(*row)["trace"].contains(kind) || !(*peer)["trace"].contains(kind))
    return std::nullopt;
  return (*row)["trace"][kind]["single"]["mrays_per_s"].get<double>() /
         (*peer)["trace"][kind]["single"]["mrays_per_s"].get<double>();
}

// Issue 5's targets, where the run has the rows they compare.
std::string bih_bvh_targets(const Json& report) {
  std::string out = "\n## Targets of issue 5 (BIH and BVH)\n\n";
  out +=
      "BIH global's build speed-up over kd binned; single-ray diffuse (and primary) throughput "
      "of our BVHs over Embree high's `rtcIntersect1` on the same rays.\n\n";
  out +=
      "| mesh | bih global speed-up over kd binned (≥ 3) | sbvh diffuse / Embree high (≥ 1.0) | "
      "binned diffuse / Embree high | sbvh primary / Embree high | binned primary / Embree "
      "high |\n";
  out += "|---|--:|--:|--:|--:|--:|\n";
  bool any = false;
  for (const Json& mesh : report["meshes"]) {
    const Json& rows = mesh["results"];
    const Json* bih = find_row(rows, "bih", "global");
    const Json* kd_binned = find_row(rows, "kd", "binned");
    const Json* sbvh = find_row(rows, "bvh", "sbvh");
    const Json* binned = find_row(rows, "bvh", "binned");
    const Json* high = find_row(rows, "embree", "high");
    if (!bih && !sbvh && !binned) continue;
    any = true;
    out += fmt::format("| {} | {} | {} | {} | {} | {} |\n", mesh["name"].get<std::string>(),
                       target(ratio(kd_binned, bih, "build_ms"), 3, true),
                       target(single_ratio(sbvh, high, "diffuse"), 1.0, true),
                       target(single_ratio(binned, high, "diffuse"), 1.0, true),
                       target(single_ratio(sbvh, high, "primary"), 1.0, true),
                       target(single_ratio(binned, high, "primary"), 1.0, true));
  }
  return any ? out : "";
}

}  // namespace

double median(std::vector<double> values) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

// The SAH constants of a build-trace run: given for every structure, or each one's default.
std::string sah_settings(const Json& settings) {
  const auto given = [&](const char* key) {
    return settings.contains(key) && !settings[key].is_null();
  };
  if (given("traversal_cost") || given("intersection_cost") || !settings.contains("sah_defaults"))
    return fmt::format(
        "K_T = {}, K_I = {}",
        given("traversal_cost") ? fmt::format("{}", settings["traversal_cost"].get<double>())
                                : "each structure's",
        given("intersection_cost") ? fmt::format("{}", settings["intersection_cost"].get<double>())
                                   : "each structure's");
  const Json& d = settings["sah_defaults"];
  return fmt::format(
      "each structure's defaults, kd K_T = {}, K_I = {}, BIH and BVH K_T = {}, "
      "K_I = {} (the SAH cost column is at the row's structure's constants)",
      d["kd"][0].get<double>(), d["kd"][1].get<double>(), d["others"][0].get<double>(),
      d["others"][1].get<double>());
}

std::string markdown_report(const Json& report) {
  const Json& machine = report["machine"];
  const Json& settings = report["settings"];
  std::string out = "# Build and trace: kd-tree, BIH and BVH builders against Embree\n\n";
  out += fmt::format(
      "Measured {} on {} ({} threads of {}), {}, Embree {}; load average {:.1f} at the start, "
      "{:.1f} at the end. Medians of {} runs after a warm-up; {} rays per kind (seed {}), the "
      "same rays for every structure; SAH constants: {}.\n\n",
      machine["date_utc"].get<std::string>(), machine["cpu"].get<std::string>(),
      machine["threads"].get<int>(), machine["hardware_threads"].get<int>(),
      machine["compiler"].get<std::string>(), machine["embree"].get<std::string>(),
      machine["load_average_start"].get<double>(), machine.value("load_average_end", -1.0),
      settings["runs"].get<int>(), settings["rays_per_kind"].get<std::uint64_t>(),
      settings["seed"].get<std::uint64_t>(), sah_settings(settings));
  out +=
      "Ratios (×) are to **Embree medium** (its default build quality) on the same mesh in the "
      "same run: build time (lower is better) and throughput (higher is better). *1-ray*: the "
      "structure's single-ray call on every core (Embree: `rtcIntersect1`); *batched*: its "
      "batched call (Embree: `rtcIntersect8` packets). *check*: hit count and id checksum against "
      "kd sah's on the same rays "
      "(Embree is not watertight and breaks ties differently, so a few rays may differ).\n\n";

  out +=
      "## Build\n\n| mesh | triangles | structure | build ms | × Embree | SAH cost (K_T/K_I) | "
      "cost evals | "
      "nodes | memory |\n";
  out += "|---|--:|---|--:|--:|--:|--:|--:|--:|\n";
  for (const Json& mesh : report["meshes"]) {
    for (const Json& row : mesh["results"]) {
      const std::string structure =
          row["accel"].get<std::string>() + " " + row["builder"].get<std::string>();
      if (row.contains("error")) {
        out += fmt::format("| {} | {} | {} | failed: {} | | | | | |\n",
                           mesh["name"].get<std::string>(), number(mesh["triangles"]), structure,
                           row["error"].get<std::string>());
        continue;
      }
      out += fmt::format(
          "| {} | {} | {} | {} | {} | {} | {} | {} | {} |\n", mesh["name"].get<std::string>(),
          number(mesh["triangles"]), structure, number(row["build_ms"]),
          row.contains("build_ratio") ? number(row["build_ratio"]) : "–",
          row["sah_cost"].is_null()
              ? std::string("–")
              : fmt::format("{} ({}/{})", number(row["sah_cost"], "{:.1f}"),
                            row["sah_kt"].get<double>(), row["sah_ki"].get<double>()),
          number(row["cost_evals"]), row["nodes"].get<std::uint64_t>() ? number(row["nodes"]) : "–",
          mib(row["bytes"].get<std::uint64_t>()));
    }
  }

  out +=
      "\n## Trace (Mrays/s)\n\n| mesh | view | structure | primary 1-ray | primary batched | "
      "diffuse 1-ray | diffuse batched | check |\n";
  out += "|---|---|---|--:|--:|--:|--:|---|\n";
  for (const Json& mesh : report["meshes"]) {
    for (const Json& row : mesh["results"]) {
      if (row.contains("error")) continue;
      std::string cells;
      for (const char* kind : {"primary", "diffuse"}) {
        if (!row["trace"].contains(kind)) {
          cells += " – | – |";
          continue;
        }
        const Json& t = row["trace"][kind];
        cells += fmt::format(" {} | {} |", with_ratio(t["single"]), with_ratio(t["batched"]));
      }
      std::string view = mesh["camera"]["view"].get<std::string>();
      if (row["trace"].contains("primary"))
        view += fmt::format(", {:.0f}% hit", 100.0 * row["trace"]["primary"]["hits"].get<double>() /
                                                 settings["rays_per_kind"].get<double>());
      out += fmt::format("| {} | {} | {} {} |{} {} |\n", mesh["name"].get<std::string>(), view,
                         row["accel"].get<std::string>(), row["builder"].get<std::string>(), cells,
                         check(row));
    }
  }

  out += "\n## Targets of issue 3\n\n";
  out +=
      "Build-time ratios are speed-ups (sah's time / the builder's); trace ratios are kd sah's "
      "tree, batched, over Embree medium's `rtcIntersect1`.\n\n";
  out +=
      "| mesh | golden speed-up (≥ 4) | golden SAH / sah (≤ 1.05) | binned speed-up (≥ 10) | "
      "binned SAH / sah (≤ 1.10) | binned time / Embree (≤ 1.5) | primary (≥ 1.0) | diffuse (≥ "
      "0.7) |\n";
  out += "|---|--:|--:|--:|--:|--:|--:|--:|\n";
  for (const Json& mesh : report["meshes"]) {
    const Json& rows = mesh["results"];
    const Json* sah = find_row(rows, "kd", "sah");
    const Json* golden = find_row(rows, "kd", "golden");
    const Json* binned = find_row(rows, "kd", "binned");
    const Json* embree = find_row(rows, "embree", "medium");
    out +=
        fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} |\n", mesh["name"].get<std::string>(),
                    target(ratio(sah, golden, "build_ms"), 4, true),
                    target(ratio(golden, sah, "sah_cost"), 1.05, false),
                    target(ratio(sah, binned, "build_ms"), 10, true),
                    target(ratio(binned, sah, "sah_cost"), 1.10, false),
                    target(ratio(binned, embree, "build_ms"), 1.5, false),
                    target(trace_target(sah, "primary"), 1.0, true),
                    target(trace_target(sah, "diffuse"), 0.7, true));
  }

  out += bih_bvh_targets(report);

  if (!report["notes"].empty()) {
    out += "\n## Notes\n\n";
    for (const Json& note : report["notes"]) out += "- " + note.get<std::string>() + "\n";
  }
  return out;
}

void emit_report(const cli::JsonOutput& json, const std::string& markdown_path,
                 const nlohmann::ordered_json& report, const std::string& markdown) {
  cli::emit_json(json, report);
  if (!markdown_path.empty())
    write_file_atomically(markdown_path, markdown);
  else if (!json.print)
    std::cout << markdown << std::flush;
}

void check_output_folders(const std::vector<std::string>& paths) {
  for (const std::string& path : paths) {
    if (path.empty()) continue;
    const auto folder = std::filesystem::absolute(path).parent_path();
    if (!std::filesystem::is_directory(folder))
      throw Error(path, "the folder " + folder.string() + " does not exist");
  }
}

ReportFile::ReportFile(const cli::JsonOutput& json, const nlohmann::ordered_json& report,
                       const std::string& name)
    : path(json.file), temporary(json.file.empty()) {
  if (!temporary) return;
  path = (std::filesystem::temp_directory_path() / fmt::format("{}-{}.json", name, ::getpid()))
             .string();
  write_file_atomically(path, report.dump(2) + "\n");
}

ReportFile::~ReportFile() {
  std::error_code ec;
  if (temporary) std::filesystem::remove(path, ec);
}

}  // namespace splitray::bench

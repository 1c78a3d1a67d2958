#include "animate_compare.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "splitray/accel/animated_accel.hpp"

namespace splitray::app {

namespace {

using Json = nlohmann::ordered_json;

double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

struct Row {
  double update_ms = 0, trace_ms = 0, sah = 0;
  std::size_t nodes = 0, mismatches = 0;
  float kt = 0, ki = 0;
};

}  // namespace

CompareResult compare_strategies(const FrameSequence& sequence,
                                 const std::vector<std::vector<Triangle>>& frames,
                                 const CompareOptions& options,
                                 const std::function<void(double)>& progress) {
  std::vector<std::string> names =
      options.strategies.empty() ? animation_strategy_names() : options.strategies;
  std::vector<std::unique_ptr<AnimatedAccel>> strategies;
  for (const std::string& name : names)
    strategies.push_back(make_animated_accel(name, options.build, options.predictor));
  // The reference of the exact strategies' hits: the kd rebuild's when it runs, else the first.
  const auto reference_it = std::find(names.begin(), names.end(), "kd-rebuild");
  const std::size_t reference =
      reference_it == names.end() ? 0 : static_cast<std::size_t>(reference_it - names.begin());
  std::vector<std::vector<Row>> rows(names.size(), std::vector<Row>(frames.size()));
  for (std::size_t f = 0; f < frames.size(); ++f) {
    std::vector<std::vector<Hit>> hits(names.size());
    for (std::size_t k = 0; k < names.size(); ++k) {
      const std::size_t s = (k + f) % names.size();  // rotating order
      AnimationFrameStats stats;
      const Accel& accel = strategies[s]->next_frame(frames[f], stats);
      FramePassResult pass = trace_frame_pass(options.pass, sequence, f, accel, frames[f]);
      Row& row = rows[s][f];
      row.update_ms = stats.update_ms;
      row.trace_ms = pass.trace_ms;
      row.sah = stats.accel.sah_cost.value_or(0);
      row.kt = stats.accel.sah_traversal_cost;
      row.ki = stats.accel.sah_intersection_cost;
      row.nodes = stats.accel.nodes;
      hits[s] = std::move(pass.hits);
    }
    // Ours must give the reference's hits exactly; Embree (its own triangle test and
    // traversal) to within a relative 1e-4 in t.
    for (std::size_t s = 0; s < names.size(); ++s) {
      const bool exact = !names[s].starts_with("embree");
      for (std::size_t r = 0; r < hits[s].size(); ++r) {
        const Hit &a = hits[s][r], &b = hits[reference][r];
        rows[s][f].mismatches +=
            exact ? a.prim != b.prim || a.t != b.t
                  : a.found() != b.found() || (b.found() && std::fabs(a.t - b.t) > 1e-4f * b.t);
      }
    }
    if (progress) progress(static_cast<double>(f + 1) / static_cast<double>(frames.size()));
  }

  CompareResult result;
  result.csv =
      "strategy,frame,update_ms,trace_ms,frame_ms,sah_cost,sah_kt,sah_ki,nodes,"
      "hit_mismatches\n";
  Json per = Json::object();
  double best_embree = std::numeric_limits<double>::infinity();
  double embree_medium_update = 0;
  std::vector<double> frame_medians(names.size());
  for (std::size_t s = 0; s < names.size(); ++s) {
    std::vector<double> update, trace, total, sah;
    std::size_t mismatches = 0;
    for (std::size_t f = 0; f < frames.size(); ++f) {
      const Row& r = rows[s][f];
      result.csv += fmt::format("{},{},{:.4f},{:.4f},{:.4f},{:.6f},{},{},{},{}\n", names[s], f,
                                r.update_ms, r.trace_ms, r.update_ms + r.trace_ms, r.sah, r.kt,
                                r.ki, r.nodes, r.mismatches);
      mismatches += r.mismatches;
      if (f == 0 && frames.size() > 1) continue;  // frame 0 is the initial build
      update.push_back(r.update_ms);
      trace.push_back(r.trace_ms);
      total.push_back(r.update_ms + r.trace_ms);
      sah.push_back(r.sah);
    }
    frame_medians[s] = median_of(total);
    const bool embree = names[s].starts_with("embree");
    if (embree) best_embree = std::min(best_embree, frame_medians[s]);
    if (names[s] == "embree-medium") embree_medium_update = median_of(update);
    per[names[s]] = {{"median_update_ms", median_of(update)},
                     {"median_trace_ms", median_of(trace)},
                     {"median_frame_ms", frame_medians[s]},
                     {"median_sah_cost", median_of(sah)},
                     {"sah_kt", rows[s][0].kt},
                     {"sah_ki", rows[s][0].ki},
                     // Ours must equal the reference exactly; Embree's own triangle test and
                     // traversal may differ in the last bits of t and break ties otherwise.
                     {"hit_mismatches", mismatches},
                     {"exact", !embree}};
  }
  for (std::size_t s = 0; s < names.size(); ++s) {
    Json& p = per[names[s]];
    p["frame_ms_vs_best_embree"] =
        std::isfinite(best_embree) ? Json(frame_medians[s] / best_embree) : Json();
    p["update_ms_vs_embree_medium"] =
        embree_medium_update > 0 ? Json(p["median_update_ms"].get<double>() / embree_medium_update)
                                 : Json();
  }
  result.summary = {{"frames", frames.size()},
                    {"triangles", frames.empty() ? 0 : frames[0].size()},
                    {"frame_pass", fmt::format("{}x{} primary + 1 shadow ray per hit",
                                               options.pass.width, options.pass.height)},
                    {"reference", names[reference]},
                    {"strategies", per}};
  result.markdown =
      "| strategy | update ms | trace ms | frame ms | frame / best Embree | update / Embree medium "
      "| "
      "SAH cost (K_T, K_I) | hit mismatches |\n|---|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const std::string& name : names) {
    const Json& p = per[name];
    const auto ratio = [](const Json& v) {
      return v.is_null() ? std::string("–") : fmt::format("{:.2f}", v.get<double>());
    };
    const std::string sah =
        p["median_sah_cost"].get<double>() > 0
            ? fmt::format("{:.1f} ({:g}, {:g})", p["median_sah_cost"].get<double>(),
                          p["sah_kt"].get<float>(), p["sah_ki"].get<float>())
            : std::string("–");
    result.markdown += fmt::format(
        "| {} | {:.2f} | {:.2f} | {:.2f} | {} | {} | {} | {}{} |\n", name,
        p["median_update_ms"].get<double>(), p["median_trace_ms"].get<double>(),
        p["median_frame_ms"].get<double>(), ratio(p["frame_ms_vs_best_embree"]),
        ratio(p["update_ms_vs_embree_medium"]), sah, p["hit_mismatches"].get<std::size_t>(),
        p["exact"].get<bool>() ? "" : " (t within 1e-4)");
  }
  return result;
}

}  // namespace splitray::app

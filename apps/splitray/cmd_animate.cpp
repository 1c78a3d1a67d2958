// splitray animate FRAMES... : kd-tree rebuilds of an animation, every frame from scratch
// (the baseline, `golden` by default, and the exact `sah` for reference) and predicted from
// the previous frames' splits by Kalman or Wiener filters (paper 000), in one process on the
// same frames. Prints per-frame rows and a summary (paper 000 Table 1); --plot draws paper
// Fig. 7 through scripts/plot_animate.py. With --accel bvh --refit the same rows and summary
// compare a BVH refitted frame after frame with one rebuilt every frame (animate_refit.hpp).
#include <fmt/core.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include "animate_compare.hpp"
#include "animate_refit.hpp"
#include "commands.hpp"
#include "dist_animate.hpp"
#include "file_options.hpp"
#include "frame_pass.hpp"
#include "frame_renderer.hpp"
#include "json_output.hpp"
#include "options.hpp"
#include "progress.hpp"
#include "splitray/accel/animated_accel.hpp"
#include "splitray/accel/embree/embree_accel.hpp"
#include "splitray/accel/kd/coherent_builder.hpp"
#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/accel/kd/predicted_builder.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/image.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/scene.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/dist/world.hpp"
#include "splitray/io/frames.hpp"
#include "splitray/io/plot_script.hpp"
#include "splitray/render/ray_sets.hpp"
#include "splitray/render/whitted.hpp"

namespace splitray::app {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

struct AnimateCommand {
  std::vector<std::string> frames;
  AccelOptions accel;
  std::string predictor = "kalman";
  PredictorConfig config;
  std::size_t max_frames = 0;
  std::size_t rays = 16384;
  int pass_width = 1024, pass_height = 768;  // the frame pass (0: none)
  std::uint64_t seed = 1;
  cli::JsonOutput json;
  bool refit = false;  // --accel bvh: refit the first frame's BVH instead of predicting splits
  std::string csv, plot, render_dir, results, name;
  int width = 640, height = 480;  // of the --render frames
  std::string mode = "whitted";   // renderer of the --render frames
  bool compare = false;           // every animation strategy on the same frames
  std::vector<std::string> strategies;
  bool render_only = false;  // --render without the comparison of builds (mpirun's way)
  bool resume = false;
  std::size_t run_length = 0;  // frames per hand-out under mpirun, 0 = auto
};

FrameImageOptions image_options(const AnimateCommand& command) {
  return {command.render_dir, command.width, command.height, command.accel.build, command.mode};
}

// The frame pass of --pass-width x --pass-height (none when either is 0).
std::optional<FramePassSetup> frame_pass(const AnimateCommand& command,
                                         const FrameSequence& sequence,
                                         const std::vector<Triangle>& first) {
  if (command.pass_width <= 0 || command.pass_height <= 0) return std::nullopt;
  return frame_pass_setup(sequence, first, command.pass_width, command.pass_height);
}

struct FrameRow {
  double build_ms_full = 0, build_ms_predicted = 0, build_ms_sah = 0;
  double sah_full = 0, sah_predicted = 0;
  std::size_t nodes_full = 0, nodes_predicted = 0;
  std::uint64_t evals_full = 0, evals_predicted = 0;
  double trace_ms_full = 0, trace_ms_predicted = 0;
  std::size_t hit_mismatches = 0;
  PredictedBuildStats predicted;
  // The strategy run's frame: its update (= build_ms_predicted) and the frame pass's trace.
  double frame_trace_ms = 0;
  std::optional<CoherentFrameStats> coherent;  // kd: the coherent rebuild's statistics
};

// The median over frames 1.. (frame 0 is the initial build) of `value(row)`.
template <class Value>
double median_from(const std::vector<FrameRow>& rows, Value value) {
  std::vector<double> v;
  for (std::size_t i = rows.size() > 1 ? 1 : 0; i < rows.size(); ++i) v.push_back(value(rows[i]));
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

// median_update_ms, median_trace_ms (the frame pass) and median_frame_ms (of their per-frame
// sums) of the strategy run, into `summary`.
void add_frame_medians(Json& summary, const std::vector<FrameRow>& rows) {
  summary["median_update_ms"] =
      median_from(rows, [](const FrameRow& r) { return r.build_ms_predicted; });
  summary["median_trace_ms"] =
      median_from(rows, [](const FrameRow& r) { return r.frame_trace_ms; });
  summary["median_frame_ms"] =
      median_from(rows, [](const FrameRow& r) { return r.build_ms_predicted + r.frame_trace_ms; });
}

double mean_from(const std::vector<FrameRow>& rows, std::size_t first, double FrameRow::*field) {
  if (rows.size() <= first) first = 0;
  double sum = 0;
  for (std::size_t i = first; i < rows.size(); ++i) sum += rows[i].*field;
  return sum / static_cast<double>(rows.size() - first);
}

// The median over frames first.. of a per-frame ratio (0 when no frame has one): robust to
// the load spikes of a shared machine, which the means are not.
double median_ratio(const std::vector<FrameRow>& rows, std::size_t first,
                    double FrameRow::*numerator, double FrameRow::*denominator) {
  if (rows.size() <= first) first = 0;
  std::vector<double> ratios;
  for (std::size_t i = first; i < rows.size(); ++i)
    if (rows[i].*denominator > 0) ratios.push_back(rows[i].*numerator / rows[i].*denominator);
  if (ratios.empty()) return 0;
  std::sort(ratios.begin(), ratios.end());
  const std::size_t m = ratios.size() / 2;
  return ratios.size() % 2 ? ratios[m] : 0.5 * (ratios[m - 1] + ratios[m]);
}

std::string optional_number(const std::optional<double>& v) {
  return v ? fmt::format("{:.9g}", *v) : "";
}

// `kd_columns` false (Embree): only the update and trace times, the kd-only columns empty.
std::string csv_text(const std::vector<FrameRow>& rows, const FrameSequence& frames,
                     const std::string& predictor, bool kd_columns = true) {
  std::ostringstream out;
  out << "frame,predictor,build_ms_full,build_ms_predicted,build_ms_sah,sah_cost_full,"
         "sah_cost_predicted,nodes_full,nodes_predicted,cost_evals_full,cost_evals_predicted,"
         "searched_nodes,predicted_nodes,fallbacks,mean_error,max_error,root_axis,root_actual,"
         "root_predicted,trace_ms_full,trace_ms_predicted,hit_mismatches,label\n";
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const FrameRow& r = rows[i];
    if (!kd_columns) {
      out << fmt::format("{},{},,{:.4f},,,,,,,,,,,,,,,,,{:.4f},0,\"{}\"\n", i, predictor,
                         r.build_ms_predicted, r.trace_ms_predicted, frames.label(i));
      continue;
    }
    out << fmt::format(
        "{},{},{:.4f},{:.4f},{:.4f},{:.6f},{:.6f},{},{},{},{},{},{},{},{:.6g},{:.6g},{},{},{},{:."
        "4f},{:.4f},{},\"{}\"\n",
        i, predictor, r.build_ms_full, r.build_ms_predicted, r.build_ms_sah, r.sah_full,
        r.sah_predicted, r.nodes_full, r.nodes_predicted, r.evals_full, r.evals_predicted,
        r.predicted.searched_nodes, r.predicted.predicted_nodes, r.predicted.fallbacks,
        r.predicted.mean_error, r.predicted.max_error, r.predicted.root_axis,
        optional_number(r.predicted.root_actual), optional_number(r.predicted.root_predicted),
        r.trace_ms_full, r.trace_ms_predicted, r.hit_mismatches, frames.label(i));
  }
  return out.str();
}

double trace_ms(const Accel& accel, std::span<const Ray> rays, std::vector<Hit>& hits) {
  hits.assign(rays.size(), Hit{});
  const Timer timer;
  accel.intersect(rays, hits);
  return timer.ms();
}

// --csv and --plot of the per-frame rows.
void write_csv_and_plot(const AnimateCommand& command, const std::string& csv,
                        const std::string& script = "plot_animate.py") {
  if (!command.csv.empty()) write_file_atomically(command.csv, csv);
  if (command.plot.empty()) return;
  const fs::path tmp =
      fs::temp_directory_path() / fmt::format("splitray-animate-{}.csv", ::getpid());
  write_file_atomically(tmp.string(), csv);
  try {
    run_plot_script(script, command.plot, tmp.string());
  } catch (...) {
    fs::remove(tmp);
    throw;
  }
  fs::remove(tmp);
}

// The sequence's name for --results: --name, else the folder of the frames (its parent when
// that is called "frames").
std::string sequence_name(const AnimateCommand& command, const FrameSequence& sequence) {
  if (!command.name.empty()) return command.name;
  fs::path dir = fs::path(sequence.label(0)).parent_path();
  if (dir.filename() == "frames" || dir.filename() == "aff") dir = dir.parent_path();
  return dir.filename().string();
}

// `text` with its results table (the lines from "| sequence" to the next line that does not
// start with '|') replaced by `table`, so that prose written around the table survives.
std::string replace_table(const std::string& text, const std::string& table) {
  std::size_t begin = text.compare(0, 10, "| sequence") == 0 ? 0 : text.find("\n| sequence");
  if (begin == std::string::npos) return text.empty() ? table : text + "\n" + table;
  if (begin > 0) ++begin;  // past the newline
  std::size_t end = begin;
  while (end < text.size() && text[end] == '|') {
    const std::size_t eol = text.find('\n', end);
    end = eol == std::string::npos ? text.size() : eol + 1;
  }
  return text.substr(0, begin) + table + text.substr(end);
}

// Merges `summary` into the results file (runs keyed "sequence/predictor") and rewrites it
// and its Markdown table (same name, .md), both atomically.
void write_results(const std::string& path, const std::string& key, const Json& summary) {
  Json all = Json::object();
  if (fs::exists(path)) {
    std::ifstream in(path);
    all = Json::parse(in, nullptr, false);
    if (all.is_discarded() || !all.is_object())
      throw Error("--results " + path, "not a JSON object; refusing to overwrite it");
  }
  all["runs"][key] = summary;
  write_file_atomically(path, all.dump(2) + "\n");
  // A number of a run, "–" where the run has none (older runs, or null: not applicable).
  const auto number = [](const Json& r, const char* name, int digits) {
    const auto it = r.find(name);
    return it == r.end() || !it->is_number() ? std::string("–")
                                             : fmt::format("{:.{}f}", it->get<double>(), digits);
  };
  std::string table =
      "| sequence / predictor | frames | triangles | full ms | predicted ms | sah ms | reduction | "
      "sah_cost_ratio | trace ms full | trace ms predicted | trace_ratio | median reduction | "
      "median trace_ratio | mean err | predicted nodes |\n"
      "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  for (const auto& [name, r] : all["runs"].items()) {
    if (r.value("accel", "") == "embree") {  // one scene updated every frame: its times only
      table += fmt::format("| {} ({:.1f} Mrays/s) | {} | {} | {:.2f} | | | | | | | | | | | |\n",
                           name, r.value("trace_mrays_per_s", 0.0), r.value("frames", 0),
                           r.value("triangles", 0), r.value("mean_build_ms", 0.0));
      continue;
    }
    table += fmt::format(
        "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n", name,
        r.value("frames", 0), r.value("triangles", 0), number(r, "mean_build_ms_full", 1),
        number(r, "mean_build_ms_predicted", 2), number(r, "mean_build_ms_sah", 1),
        number(r, "reduction", 3), number(r, "sah_cost_ratio", 4),
        number(r, "mean_trace_ms_full", 2), number(r, "mean_trace_ms_predicted", 2),
        number(r, "trace_ratio", 3), number(r, "median_reduction", 3),
        number(r, "median_trace_ratio", 3), number(r, "mean_prediction_error", 4),
        number(r, "predicted_node_share", 2));
  }
  fs::path md_path(path);
  md_path.replace_extension(".md");
  std::string old;
  if (fs::exists(md_path)) {
    std::ifstream in(md_path);
    old.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  write_file_atomically(md_path.string(), replace_table(old, table));
}

// Embree as users drive it through an animation: one scene, its vertices updated and the
// scene committed again every frame (a refit with --builder refit, else a rebuild).
void run_embree(const AnimateCommand& command, const FrameSequence& sequence,
                const std::vector<std::vector<Triangle>>& frames) {
  std::vector<double> ms;
  double trace_total_ms = 0;  // primary rays per frame: what a refit costs in tracing speed
  std::vector<Hit> hits;
  std::vector<FrameRow> rows(frames.size());
  FrameRenderer renderer(sequence, frames[0], image_options(command));
  cli::ProgressBar bar("animate");
  Timer timer;
  const auto scene = make_embree_scene(frames[0], command.accel.build);
  const std::optional<FramePassSetup> pass = frame_pass(command, sequence, frames[0]);
  ms.push_back(timer.ms());
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (i > 0) ms.push_back(scene->update(frames[i]));
    rows[i].build_ms_predicted = ms[i];
    if (pass)
      rows[i].frame_trace_ms = trace_frame_pass(*pass, sequence, i, *scene, frames[i]).trace_ms;
    if (command.rays > 0) {
      const std::vector<Ray> rays =
          make_rays(frames[i], RayKind::primary, command.seed + i, command.rays);
      rows[i].trace_ms_predicted = trace_ms(*scene, rays, hits);
      trace_total_ms += rows[i].trace_ms_predicted;
    }
    renderer.render(i, frames[i]);
    bar.update(static_cast<double>(i + 1) / static_cast<double>(frames.size()));
  }
  bar.finish();
  const double mrays = trace_total_ms > 0 ? static_cast<double>(command.rays * frames.size()) /
                                                (trace_total_ms * 1e3)
                                          : 0;
  double sum = 0;
  for (std::size_t i = ms.size() > 1 ? 1 : 0; i < ms.size(); ++i) sum += ms[i];
  const double mean = sum / static_cast<double>(ms.size() > 1 ? ms.size() - 1 : 1);
  const std::string builder = scene->stats().builder;
  Json summary = {{"frames", frames.size()},
                  {"triangles", frames[0].size()},
                  {"accel", "embree"},
                  {"builder", builder},
                  {"mean_build_ms", mean},
                  {"first_build_ms", ms[0]},
                  {"rays_per_frame", command.rays},
                  {"trace_mrays_per_s", mrays},
                  {"threads", effective_threads(command.accel.build.threads)},
                  {"first_frame", sequence.label(0)},
                  {"build_ms", ms}};
  add_frame_medians(summary, rows);
  write_csv_and_plot(command, csv_text(rows, sequence, "embree-" + builder, false));
  if (!command.results.empty())
    write_results(command.results, sequence_name(command, sequence) + "/embree-" + builder,
                  summary);
  cli::emit_json(command.json, summary);
  if (!command.json.print) {
    for (std::size_t i = 0; i < ms.size(); ++i)
      fmt::print("frame {:4d}  build_ms {:9.3f}\n", i, ms[i]);
    print_table(
        {{"frames", std::to_string(frames.size())},
         {"triangles", std::to_string(frames[0].size())},
         {"mean_build_ms (embree " + builder + ", frames 1..)", fmt::format("{:.3f}", mean)}});
  }
}

void report(const AnimateCommand& command, const FrameSequence& sequence,
            const std::vector<std::vector<Triangle>>& frames, const std::vector<FrameRow>& rows,
            const std::string& builder);

// --compare: every strategy of the animation interface on the same frames (animate_compare.hpp).
void run_compare(const AnimateCommand& command, const FrameSequence& sequence,
                 const std::vector<std::vector<Triangle>>& frames) {
  CompareOptions options;
  options.strategies = command.strategies;
  options.build = command.accel.build;
  options.predictor = command.config;
  options.pass = frame_pass_setup(sequence, frames[0], std::max(command.pass_width, 1),
                                  std::max(command.pass_height, 1));
  cli::ProgressBar bar("compare");
  const CompareResult result =
      compare_strategies(sequence, frames, options, [&](double done) { bar.update(done); });
  bar.finish();
  write_csv_and_plot(command, result.csv, "plot_frame_times.py");
  Json summary = result.summary;
  summary["sequence"] = sequence_name(command, sequence);
  summary["threads"] = effective_threads(command.accel.build.threads);
  summary["first_frame"] = sequence.label(0);
  cli::emit_json(command.json, summary);
  if (!command.json.print) fmt::print("{}", result.markdown);
}

// --render-only, --resume and every run under mpirun: the frames rendered only, handed out
// to the ranks (dist_animate.hpp); rank 0 reports.
void run_render(const AnimateCommand& command, const FrameSequence& sequence) {
  if (command.render_dir.empty())
    throw Error(dist::world().distributed() ? "mpirun" : "--render-only",
                "animate renders frames here: give --render DIR");
  if (command.accel.accel != "kd")
    throw Error("--accel " + command.accel.accel,
                "frames are rendered through predicted kd rebuilds (--accel kd) when rendering "
                "only or under mpirun");
  for (const auto& [name, value] : {std::pair{"--csv", &command.csv},
                                    {"--plot", &command.plot},
                                    {"--results", &command.results}})
    if (!value->empty())
      throw Error(name,
                  "compares builds in one process: not with --render-only, --resume or "
                  "under mpirun");
  const ThreadLimit limit(command.accel.build.threads);
  const bool lead = dist::world().rank == 0;
  cli::ProgressBar bar(lead ? "render" : "");
  AnimationRenderOptions options;
  options.image = image_options(command);
  options.build = command.accel.build;
  options.predictor = command.config;
  options.max_frames = command.max_frames;
  options.run_length = command.run_length;
  options.resume = command.resume;
  options.progress = [&](double done) { bar.update(done); };
  const AnimationRender result = render_animation(sequence, options);
  bar.finish();
  if (!lead) return;
  std::vector<RenderedFrame> frames = result.rendered;
  std::sort(frames.begin(), frames.end(),
            [](const RenderedFrame& a, const RenderedFrame& b) { return a.frame < b.frame; });
  const double per_s =
      result.wall_ms > 0 ? 1e3 * static_cast<double>(frames.size()) / result.wall_ms : 0;
  Json rendered = Json::array(), ranks = Json::array();
  for (const RenderedFrame& f : frames)
    rendered.push_back({{"frame", f.frame},
                        {"rank", f.rank},
                        {"predicted", f.predicted},
                        {"load_ms", f.load_ms},
                        {"build_ms", f.build_ms},
                        {"render_ms", f.render_ms},
                        {"rays", f.rays}});
  for (const dist::RankStats& r : result.ranks)
    ranks.push_back({{"rank", r.rank},
                     {"frames", r.units},
                     {"compute_ms", r.compute_ms},
                     {"comm_ms", r.comm_ms},
                     {"assembly_ms", r.collect_ms},
                     {"idle_ms", r.idle_ms}});
  const Json summary = {{"frames", result.frames},
                        {"rendered", frames.size()},
                        {"kept", result.kept},
                        {"dir", command.render_dir},
                        {"width", command.width},
                        {"height", command.height},
                        {"ranks", result.ranks.size()},
                        {"run_length", result.run_length},
                        {"predictor", command.predictor},
                        {"threads", effective_threads(command.accel.build.threads)},
                        {"wall_ms", result.wall_ms},
                        {"frames_per_s", per_s},
                        {"frame_rows", rendered},
                        {"rank_stats", ranks}};
  cli::emit_json(command.json, summary);
  if (command.json.print) return;
  fmt::print("{:>5} {:>4} {:>9} {:>9} {:>9} {:>10}\n", "frame", "rank", "predicted", "load_ms",
             "build_ms", "render_ms");
  for (const RenderedFrame& f : frames)
    fmt::print("{:5d} {:4d} {:>9} {:9.2f} {:9.2f} {:10.2f}\n", f.frame, f.rank,
               f.predicted ? "yes" : "no", f.load_ms, f.build_ms, f.render_ms);
  fmt::print("{:>4} {:>6} {:>11} {:>9} {:>12} {:>9}\n", "rank", "frames", "compute_ms", "comm_ms",
             "assembly_ms", "idle_ms");
  for (const dist::RankStats& r : result.ranks)
    fmt::print("{:4d} {:6d} {:11.1f} {:9.1f} {:12.1f} {:9.1f}\n", r.rank, r.units, r.compute_ms,
               r.comm_ms, r.collect_ms, r.idle_ms);
  print_table({{"frames", std::to_string(result.frames)},
               {"rendered", std::to_string(frames.size())},
               {"kept (--resume: complete already)", std::to_string(result.kept.size())},
               {"ranks", std::to_string(result.ranks.size())},
               {"run_length", std::to_string(result.run_length)},
               {"wall_ms", fmt::format("{:.1f}", result.wall_ms)},
               {"frames_per_s", fmt::format("{:.3f}", per_s)}});
}

void run(AnimateCommand command) {
  const FrameSequence sequence(command.frames);
  command.config.kind = parse_predictor_kind(command.predictor);
  if (command.render_only || command.resume || dist::launched())
    return run_render(command, sequence);
  std::vector<std::vector<Triangle>> frames;
  {
    cli::ProgressBar bar("loading");
    bar.status("loading " + std::to_string(sequence.size()) + " frames");
    frames = load_frames(sequence, command.max_frames);
  }
  const ThreadLimit limit(command.accel.build.threads);
  if (command.compare) return run_compare(command, sequence, frames);
  if (command.refit && command.accel.accel != "bvh")
    throw Error("--refit", "only BVHs refit (--accel bvh --refit); kd-trees are rebuilt");
  if (command.accel.accel == "embree") return run_embree(command, sequence, frames);
  if (command.accel.accel == "bvh") {
    if (!command.refit) throw Error("--accel bvh", "animate refits BVHs: add --refit");
    cli::ProgressBar bar("animate");
    const std::vector<RefitFrame> refits =
        refit_frames(frames, command.accel.build, command.rays, command.seed,
                     [&](double done) { bar.update(done); });
    bar.finish();
    std::vector<FrameRow> rows(refits.size());
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const RefitFrame& f = refits[i];
      FrameRow& r = rows[i];
      r.build_ms_full = f.rebuild_ms;
      r.build_ms_predicted = f.refit_ms;
      r.build_ms_sah = f.reference_ms;
      r.sah_full = f.sah_rebuild;
      r.sah_predicted = f.sah_refit;
      r.nodes_full = f.nodes_rebuild;
      r.nodes_predicted = f.nodes_refit;
      r.evals_full = f.evals_rebuild;  // a refit evaluates no SAH cost
      r.trace_ms_full = f.trace_ms_rebuild;
      r.trace_ms_predicted = f.trace_ms_refit;
      r.hit_mismatches = f.hit_mismatches;
    }
    // The frame pass through the refitted BVH (the same refits, by the animation interface).
    if (const std::optional<FramePassSetup> pass = frame_pass(command, sequence, frames[0])) {
      BuildConfig config = command.accel.build;
      const auto refitted = make_animated_accel("bvh-refit", config);
      for (std::size_t i = 0; i < frames.size(); ++i) {
        AnimationFrameStats stats;
        const Accel& accel = refitted->next_frame(frames[i], stats);
        rows[i].frame_trace_ms = trace_frame_pass(*pass, sequence, i, accel, frames[i]).trace_ms;
      }
    }
    FrameRenderer renderer(sequence, frames[0], image_options(command));
    for (std::size_t i = 0; i < frames.size(); ++i) renderer.render(i, frames[i]);
    const std::string builder =
        command.accel.build.builder.empty() ? "binned" : command.accel.build.builder;
    return report(command, sequence, frames, rows, builder);
  }
  if (command.accel.accel != "kd")
    throw Error("--accel " + command.accel.accel,
                "animate rebuilds kd-trees (--accel kd), refits BVHs (--accel bvh --refit) or "
                "rebuilds Embree (--accel embree)");

  BuildConfig base = command.accel.build;
  if (base.builder.empty()) base.builder = "golden";
  kd_builder(base.builder);  // an unknown name fails here
  BuildConfig sah = base;
  sah.builder = "sah";
  BuildConfig golden = base;  // the coherent rebuild's from-scratch builder
  golden.builder = "golden";
  KdCoherentBuilder coherent(golden, command.config);
  const std::optional<FramePassSetup> pass = frame_pass(command, sequence, frames[0]);
  std::vector<FrameRow> rows(frames.size());
  FrameRenderer renderer(sequence, frames[0], image_options(command));
  cli::ProgressBar bar("animate");
  std::vector<Hit> hits_full, hits_predicted;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const std::vector<Triangle>& tris = frames[i];
    FrameRow& row = rows[i];
    // Alternate which build runs first, as for the traces below, so that neither always
    // inherits the other's caches and allocator state.
    std::unique_ptr<Accel> full, predicted;
    for (int turn = 0; turn < 2; ++turn) {
      const Timer timer;
      if ((turn == 0) == (i % 2 == 0)) {
        full = make_kd(tris, base);
        row.build_ms_full = timer.ms();
      } else {
        CoherentFrameStats c;
        predicted = coherent.next_frame(tris, c);
        row.build_ms_predicted = timer.ms();
        row.coherent = c;
        row.predicted.predicted_nodes = c.reoptimised_nodes;
        row.predicted.searched_nodes = c.reoptimised_nodes + (c.from_scratch ? 0 : c.reused_nodes);
        row.predicted.errors = c.forecasts;
        row.predicted.mean_error = c.mean_error;
        row.predicted.max_error = c.max_error;
        row.predicted.root_axis = c.root_axis;
        row.predicted.root_actual = c.root_actual;
        row.predicted.root_predicted = c.root_predicted;
      }
    }
    Timer timer;
    if (base.builder == "sah") {
      row.build_ms_sah = row.build_ms_full;
    } else {
      timer.reset();
      const auto exact = make_kd(tris, sah);
      row.build_ms_sah = timer.ms();
    }
    row.sah_full = full->stats().sah_cost.value_or(0);
    row.sah_predicted = predicted->stats().sah_cost.value_or(0);
    row.nodes_full = full->stats().nodes;
    row.nodes_predicted = predicted->stats().nodes;
    row.evals_full = full->stats().cost_evals;
    row.evals_predicted = predicted->stats().cost_evals;
    if (command.rays > 0) {
      const std::vector<Ray> rays =
          make_rays(tris, RayKind::primary, command.seed + i, command.rays);
      // Alternate the order so that neither tree always runs on warm caches.
      if (i % 2 == 0) {
        row.trace_ms_full = trace_ms(*full, rays, hits_full);
        row.trace_ms_predicted = trace_ms(*predicted, rays, hits_predicted);
      } else {
        row.trace_ms_predicted = trace_ms(*predicted, rays, hits_predicted);
        row.trace_ms_full = trace_ms(*full, rays, hits_full);
      }
      for (std::size_t r = 0; r < rays.size(); ++r)
        row.hit_mismatches +=
            hits_full[r].prim != hits_predicted[r].prim || hits_full[r].t != hits_predicted[r].t;
    }
    if (pass) row.frame_trace_ms = trace_frame_pass(*pass, sequence, i, *predicted, tris).trace_ms;
    renderer.render(i, tris);
    bar.update(static_cast<double>(i + 1) / frames.size());
  }
  bar.finish();
  report(command, sequence, frames, rows, base.builder);
}

// The coherent rebuild's frames 1..: per frame its nodes by origin, its time's parts, and the
// frames it built from scratch (with why).
Json coherent_summary(const std::vector<FrameRow>& rows) {
  Json frames = Json::array();
  double reused = 0, reoptimised = 0, rebuilt = 0, counted = 0;
  std::size_t scratch = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const auto& c = rows[i].coherent;
    if (!c) continue;
    frames.push_back({{"frame", i},
                      {"reused_nodes", c->reused_nodes},
                      {"reoptimised_nodes", c->reoptimised_nodes},
                      {"rebuilt_nodes", c->rebuilt_nodes},
                      {"rebuilt_subtrees", c->rebuilt_subtrees},
                      {"from_scratch", c->from_scratch},
                      {"reason", c->reason},
                      {"distribute_ms", c->distribute_ms},
                      {"search_ms", c->search_ms},
                      {"rebuild_ms", c->rebuild_ms},
                      {"predict_ms", c->predict_ms},
                      {"layout_ms", c->layout_ms},
                      {"total_ms", c->total_ms}});
    if (i == 0) continue;
    const double nodes =
        static_cast<double>(c->reused_nodes + c->reoptimised_nodes + c->rebuilt_nodes);
    reused += c->reused_nodes / nodes, reoptimised += c->reoptimised_nodes / nodes;
    rebuilt += c->rebuilt_nodes / nodes, counted += 1;
    scratch += c->from_scratch;
  }
  if (counted == 0) return Json();
  return {{"mean_reused_share", reused / counted},
          {"mean_reoptimised_share", reoptimised / counted},
          {"mean_rebuilt_share", rebuilt / counted},
          {"scratch_frames", scratch},
          {"frames", frames}};
}

// Summary, CSV, plot and results of the per-frame rows: kd rebuilds (full = from scratch,
// predicted = Kalman/Wiener) or, with --refit, BVHs (full = rebuilt, predicted = refitted,
// sah = sbvh); means over frames 1.. (frame 0 has nothing to predict from or refit).
void report(const AnimateCommand& command, const FrameSequence& sequence,
            const std::vector<std::vector<Triangle>>& frames, const std::vector<FrameRow>& rows,
            const std::string& builder) {
  // Means over frames 1.. (frame 0 has nothing to predict from), as in paper 000 Table 1.
  const double full_ms = mean_from(rows, 1, &FrameRow::build_ms_full);
  const double predicted_ms = mean_from(rows, 1, &FrameRow::build_ms_predicted);
  const double sah_ms = mean_from(rows, 1, &FrameRow::build_ms_sah);
  const double sah_ratio =
      mean_from(rows, 0, &FrameRow::sah_predicted) / mean_from(rows, 0, &FrameRow::sah_full);
  const double trace_full = mean_from(rows, 0, &FrameRow::trace_ms_full);
  const double trace_predicted = mean_from(rows, 0, &FrameRow::trace_ms_predicted);
  const double trace_ratio = trace_predicted > 0 ? trace_full / trace_predicted : 0;
  std::size_t mismatches = 0, errors = 0;
  double error_sum = 0, error_max = 0, evals_full = 0, evals_predicted = 0, predicted_nodes = 0,
         searched = 0;
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const FrameRow& r = rows[i];
    mismatches += r.hit_mismatches;
    error_sum += r.predicted.mean_error * static_cast<double>(r.predicted.errors);
    errors += r.predicted.errors;
    error_max = std::max(error_max, r.predicted.max_error);
    if (i > 0 || rows.size() == 1) {
      evals_full += static_cast<double>(r.evals_full);
      evals_predicted += static_cast<double>(r.evals_predicted);
      predicted_nodes += static_cast<double>(r.predicted.predicted_nodes);
      searched += static_cast<double>(r.predicted.searched_nodes);
    }
  }
  const double counted = static_cast<double>(rows.size() > 1 ? rows.size() - 1 : 1);
  const std::string predictor = command.refit ? "refit" : command.predictor;
  const auto predicted_only = [&](double value) { return command.refit ? Json() : Json(value); };

  write_csv_and_plot(command, csv_text(rows, sequence, predictor));

  Json summary = {
      {"frames", rows.size()},
      {"triangles", frames[0].size()},
      {"mean_build_ms_full", full_ms},
      {"mean_build_ms_predicted", predicted_ms},
      {"mean_build_ms_sah", sah_ms},
      {"reduction", full_ms > 0 ? 1 - predicted_ms / full_ms : 0},
      {"sah_cost_ratio", sah_ratio},
      {"trace_ratio", trace_ratio},
      {"median_reduction",
       1 - median_ratio(rows, 1, &FrameRow::build_ms_predicted, &FrameRow::build_ms_full)},
      {"median_trace_ratio",
       median_ratio(rows, 0, &FrameRow::trace_ms_full, &FrameRow::trace_ms_predicted)},
      {"mean_trace_ms_full", trace_full},
      {"mean_trace_ms_predicted", trace_predicted},
      {"accel", command.accel.accel},
      {"predictor", predictor},
      {"builder", builder},
      // Nothing is predicted when refitting: null.
      {"mean_prediction_error",
       predicted_only(errors ? error_sum / static_cast<double>(errors) : 0)},
      {"max_prediction_error", predicted_only(error_max)},
      {"predicted_node_share", predicted_only(searched > 0 ? predicted_nodes / searched : 0)},
      {"mean_cost_evals_full", evals_full / counted},
      {"mean_cost_evals_predicted", evals_predicted / counted},
      {"rays_per_frame", command.rays},
      {"hit_mismatches", mismatches},
      {"threads", effective_threads(command.accel.build.threads)},
      {"first_frame", sequence.label(0)},
  };
  add_frame_medians(summary, rows);
  // The constants every SAH cost above was computed with (the structure's defaults unless
  // --kt/--ki were given).
  const SahConstants sah =
      command.accel.build.sah(command.accel.accel == "kd" ? kKdSah : kSharedSah);
  summary["sah_kt"] = sah.traversal;
  summary["sah_ki"] = sah.intersection;
  summary["frame_pass"] = command.pass_width > 0 && command.pass_height > 0
                              ? Json(fmt::format("{}x{} primary + 1 shadow ray per hit",
                                                 command.pass_width, command.pass_height))
                              : Json();
  summary["coherent"] = command.refit ? Json() : coherent_summary(rows);
  if (!command.results.empty())
    write_results(command.results,
                  sequence_name(command, sequence) + "/" +
                      (command.refit ? "bvh-" + builder + "-refit" : command.predictor),
                  summary);
  cli::emit_json(command.json, summary);
  if (command.json.print) return;
  if (command.refit)
    fmt::print("full = rebuilt, pred = refitted ({}), sah = sbvh rebuilt\n", builder);
  fmt::print(
      "{:>5} {:>10} {:>10} {:>10} {:>9} {:>9} {:>8} {:>9} {:>9} {:>8} {:>8} {:>9} {:>9} {:>9}\n",
      "frame", "full_ms", "pred_ms", "sah_ms", "sah_full", "sah_pred", "nodes", "evals_f",
      "evals_p", "err_mean", "err_max", "trace_f", "trace_p", "pass_ms");
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const FrameRow& r = rows[i];
    fmt::print(
        "{:5d} {:10.3f} {:10.3f} {:10.3f} {:9.3f} {:9.3f} {:8d} {:9d} {:9d} {:8.4f} {:8.4f} "
        "{:9.3f} {:9.3f} {:9.3f}\n",
        i, r.build_ms_full, r.build_ms_predicted, r.build_ms_sah, r.sah_full, r.sah_predicted,
        r.nodes_predicted, r.evals_full, r.evals_predicted, r.predicted.mean_error,
        r.predicted.max_error, r.trace_ms_full, r.trace_ms_predicted, r.frame_trace_ms);
  }
  if (!command.refit) {  // the coherent rebuild, frame by frame
    fmt::print(
        "coherent rebuild: nodes reused / re-optimised / rebuilt (subtrees), CPU ms of "
        "distribution / local search / rebuilt subtrees / filters / layout\n");
    for (std::size_t i = 0; i < rows.size(); ++i)
      if (const auto& c = rows[i].coherent)
        fmt::print("{:5d} {:8d} {:6d} {:8d} ({:5d}) {:8.2f} {:7.2f} {:8.2f} {:6.2f} {:7.2f}  {}\n",
                   i, c->reused_nodes, c->reoptimised_nodes, c->rebuilt_nodes, c->rebuilt_subtrees,
                   c->distribute_ms, c->search_ms, c->rebuild_ms, c->predict_ms, c->layout_ms,
                   c->reason);
  }
  std::vector<std::pair<std::string, std::string>> table;
  for (const auto& [key, value] : summary.items())
    table.emplace_back(key, value.is_number_float() ? fmt::format("{:.4f}", value.get<double>())
                            : value.is_null()       ? "n/a"
                                                    : value.dump());
  print_table(table);
}

}  // namespace

void add_animate_command(CLI::App& app) {
  auto command = std::make_shared<AnimateCommand>();
  CLI::App* sub = app.add_subcommand(
      "animate",
      "Rebuild kd-trees over the frames of an animation, from scratch and predicted from the "
      "previous frames' splits (Kalman / Wiener filters, paper 000); or refit a BVH "
      "(--accel bvh --refit) against rebuilding it");
  sub->add_option("frames", command->frames,
                  "Frames: mesh files, a glob, a printf pattern (horse-%02d.obj.gz), a folder, "
                  "one MD2 file or one BART .aff scene")
      ->required();
  add_accel_options(*sub, command->accel, false);  // --compare builds other structures too
  sub->add_option("-p,--predictor", command->predictor, "none, kalman or wiener")
      ->check(CLI::IsMember({"none", "kalman", "wiener"}));
  sub->add_option("--frames", command->max_frames, "Use only the first N frames (0 = all)");
  sub->add_option("--rays", command->rays, "Primary rays per frame for trace_ratio (0 = none)");
  sub->add_option("--seed", command->seed, "Seed of the ray sets");
  sub->add_flag("--compare", command->compare,
                "Run every animation strategy (kd-coherent, kd-rebuild, bvh-refit, bvh-rebuild, "
                "embree-refit, embree-low, embree-medium) on the same frames: median update, "
                "trace and frame ms, SAH cost, hit mismatches; Markdown table, --json, --csv, "
                "--plot (update and trace time per frame)");
  sub->add_option("--strategies", command->strategies,
                  "With --compare: only these strategies (default: all)")
      ->check(CLI::IsMember(animation_strategy_names()));
  sub->add_option("--pass-width", command->pass_width,
                  "Frame time: width of the primary pass traced every frame (plus one shadow ray "
                  "per hit towards the light), reported as median_trace_ms; 0 = none")
      ->check(CLI::Range(0, 16384))
      ->capture_default_str();
  sub->add_option("--pass-height", command->pass_height, "Frame time: height of that pass")
      ->check(CLI::Range(0, 16384))
      ->capture_default_str();
  sub->add_option("--sigmas", command->config.sigmas,
                  "Bracket half width in predicted standard deviations");
  sub->add_option("--min-bracket", command->config.min_half_width,
                  "Smallest bracket half width (fraction of the cell)");
  sub->add_option("--kalman-q", command->config.kalman.process_noise,
                  "Kalman process noise (cell fractions^2)");
  sub->add_option("--kalman-r", command->config.kalman.measurement_noise,
                  "Kalman measurement noise (cell fractions^2)");
  sub->add_option("--wiener-order", command->config.wiener.order, "Wiener filter taps")
      ->check(CLI::Range(1, kWienerMaxOrder));
  sub->add_option("--wiener-step", command->config.wiener.step, "NLMS step size mu");
  sub->add_option("--refresh", command->config.refresh_frames,
                  "Re-check a node's other axes at least every N frames");
  sub->add_flag("--refit", command->refit,
                "With --accel bvh: refit the first frame's BVH to every frame; 'full' is the "
                "BVH rebuilt every frame, 'predicted' the refitted one, 'sah' sbvh rebuilt");
  cli::add_json_options(*sub, command->json, "the summary");
  sub->add_option("--csv", command->csv, "Write per-frame rows to this CSV file");
  sub->add_option("--plot", command->plot,
                  "Draw build times and root splits (paper Fig. 7) to this PNG");
  sub->add_option(
      "--results", command->results,
      "Merge the summary into this JSON file (and its .md table), keyed sequence/predictor");
  sub->add_option("--name", command->name,
                  "Name of the sequence in --results (default: its folder)");
  sub->add_option("--render", command->render_dir,
                  "Render every frame as a PNG into this folder (BART scenes: with their camera "
                  "path, lights and materials)");
  sub->add_option("-W,--width", command->width, "Width of the --render frames in pixels")
      ->check(CLI::Range(1, 16384));
  sub->add_option("-H,--height", command->height, "Height of the --render frames in pixels")
      ->check(CLI::Range(1, 16384));
  sub->add_option("--mode", command->mode,
                  "Renderer of the --render frames: whitted (CPU ray tracing) or hybrid (paper "
                  "002: GPU primary rays and shadow maps + CPU secondary and exact shadow rays, "
                  "headless OpenGL; also under mpirun, one context per rank)")
      ->check(CLI::IsMember({"whitted", "hybrid"}));
  sub->add_flag("--render-only", command->render_only,
                "Only render the frames (predicted kd rebuilds, no comparison of builds): what "
                "every run under mpirun does, with frames handed out to the ranks");
  sub->add_flag("--resume", command->resume,
                "With --render: render only the frames whose PNG is missing or incomplete "
                "(each output decoded and checked); implies --render-only");
  sub->add_option("--run-length", command->run_length,
                  "Under mpirun: consecutive frames per hand-out, over which a rank keeps its "
                  "predictor (0 = about a quarter of each rank's share, at most 16)");
  cli::input_files(sub->get_option("frames"));
  for (const char* name : {"--csv", "--plot", "--results"}) cli::output_file(sub->get_option(name));
  sub->callback([command] { run(*command); });
}

}  // namespace splitray::app

#include "dist_bench.hpp"

#include <fcntl.h>
#include <fmt/core.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <thread>

#include "bench_meshes.hpp"
#include "bench_report.hpp"
#include "machine.hpp"
#include "splitray/core/errors.hpp"

namespace splitray::bench {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

// The splitray program: this one, or the build tree's when this is splitray_bench.
fs::path splitray_program() {
  std::error_code error;
  const fs::path self = fs::read_symlink("/proc/self/exe", error);
  if (!error && self.filename() == "splitray") return self;
  const fs::path sibling = self.parent_path() / ".." / "apps" / "splitray" / "splitray";
  if (!error && ::access(sibling.c_str(), X_OK) == 0) return sibling;
  throw Error("bench dist",
              "cannot find the splitray program (next to this one or in the build "
              "tree's apps/splitray)");
}

// Runs argv[0] (looked up on PATH) and waits; stdout is dropped, stderr goes to `err`.
// Returns the exit status (128 + signal when killed).
int run_program(const std::vector<std::string>& args, const fs::path& err) {
  std::vector<char*> argv;
  std::vector<std::string> owned = args;
  for (std::string& a : owned) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t child = ::fork();
  if (child < 0) throw Error("bench dist", "cannot start " + args[0]);
  if (child == 0) {
    const int out = ::open("/dev/null", O_WRONLY);
    const int log = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int in = ::open("/dev/null", O_RDONLY);
    if (out < 0 || log < 0 || in < 0) ::_exit(126);
    ::dup2(in, 0);
    ::dup2(out, 1);
    ::dup2(log, 2);
    ::execvp(argv[0], argv.data());
    ::_exit(127);
  }
  int status = 0;
  while (::waitpid(child, &status, 0) < 0) {
  }
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The frames written into `dir`, by name.
std::map<std::string, std::string> images(const fs::path& dir) {
  std::map<std::string, std::string> out;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.path().extension() == ".png") out[entry.path().filename()] = read_text(entry.path());
  return out;
}

struct Run {
  Json report;
  std::map<std::string, std::string> frames;
};

// One `animate --render` run: ranks 0 = the single process (no MPI).
Run animate(const fs::path& program, int ranks, const DistBenchOptions& o, const fs::path& work,
            int index) {
  const fs::path out = work / fmt::format("ranks{}-{}", ranks, index);
  const fs::path report = work / fmt::format("ranks{}-{}.json", ranks, index);
  const fs::path err = work / "stderr.txt";
  std::vector<std::string> args = {program.string(),
                                   "animate",
                                   o.frames,
                                   "--frames",
                                   std::to_string(o.frame_count),
                                   "-W",
                                   std::to_string(o.width),
                                   "-H",
                                   std::to_string(o.height),
                                   "-t",
                                   "1",
                                   "--rays",
                                   "0",
                                   "--mode",
                                   o.mode,
                                   "--render",
                                   out.string(),
                                   "--json-out",
                                   report.string()};
  if (ranks == 0) {
    args.push_back("--render-only");
  } else {
    args.insert(args.begin(),
                {"mpirun", "--oversubscribe", "--mca", "btl_vader_single_copy_mechanism", "none",
                 "-np", std::to_string(ranks)});
  }
  const int status = run_program(args, err);
  if (status != 0) {
    std::string command;
    for (const std::string& a : args) command += (command.empty() ? "" : " ") + a;
    throw Error("bench dist",
                command + " failed (exit " + std::to_string(status) + "): " + read_text(err));
  }
  Run run;
  run.report = Json::parse(read_text(report));
  run.frames = images(out);
  fs::remove_all(out);
  return run;
}

std::string markdown(const Json& r) {
  std::string md = fmt::format("# splitray animate across ranks ({}, {} cores)\n\n",
                               r["machine"]["cpu"].get<std::string>(), r["cores"].get<int>());
  md += fmt::format("{} frames of {} at {}x{} ({}), one thread per rank, medians of {} runs.\n\n",
                    r["frames"].get<std::size_t>(), r["sequence"].get<std::string>(),
                    r["width"].get<int>(), r["height"].get<int>(), r["mode"].get<std::string>(),
                    r["runs"].get<int>());
  md +=
      "| ranks | frames/s | vs single process | vs 1 rank | comm + assembly | share | images "
      "identical |\n|---|---|---|---|---|---|---|\n";
  for (const Json& row : r["rows"]) {
    const std::string name =
        row["ranks"].get<int>() == 0
            ? "single process"
            : std::to_string(row["ranks"].get<int>()) +
                  (row["oversubscribed"].get<bool>() ? " (over-subscribed)" : "");
    md += fmt::format(
        "| {} | {:.2f} | {:.2f}x | {:.2f}x | {:.0f} ms | {:.1f}% | {} |\n", name,
        row["frames_per_s"].get<double>(), row["speedup_vs_single"].get<double>(),
        row["speedup_vs_one_rank"].get<double>(), row["comm_and_assembly_ms"].get<double>(),
        100 * row["comm_share"].get<double>(), row["identical_images"].get<bool>() ? "yes" : "NO");
  }
  md +=
      "\nProjection: " + r["projection_model"].get<std::string>() +
      "\n\n| nodes | ranks | frames/s | speedup vs 1 rank | efficiency |\n|---|---|---|---|---|\n";
  for (const Json& p : r["projection"])
    md += fmt::format("| {} | {} | {:.1f} | {:.1f}x | {:.0f}% |\n", p["nodes"].get<int>(),
                      p["ranks"].get<int>(), p["frames_per_s"].get<double>(),
                      p["speedup_vs_one_rank"].get<double>(), 100 * p["efficiency"].get<double>());
  return md;
}

}  // namespace

void add_dist_bench_options(CLI::App& command, DistBenchOptions& options) {
  command.add_option("--frames-of", options.frames,
                     "The animation (any frames argument of animate; default: "
                     "../shared/data/anim_horse_collapse/frames)");
  command.add_option("--frames", options.frame_count, "Frames rendered per run")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command.add_option("-W,--width", options.width, "Frame width in pixels")
      ->check(CLI::Range(1, 16384))
      ->capture_default_str();
  command.add_option("-H,--height", options.height, "Frame height in pixels")
      ->check(CLI::Range(1, 16384))
      ->capture_default_str();
  command.add_option("--ranks", options.ranks, "Rank counts to run under mpirun")
      ->check(CLI::Range(1, 1024))
      ->capture_default_str();
  command.add_option("--runs", options.runs, "Runs per rank count (median)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  command.add_option("--mode", options.mode, "Renderer of the frames: whitted or hybrid")
      ->check(CLI::IsMember({"whitted", "hybrid"}))
      ->capture_default_str();
  cli::add_json_options(command, options.json, "the full report");
  command.add_option("--markdown", options.markdown_path,
                     "Write the Markdown tables to this file (default: print them)");
}

Json run_dist_bench(const DistBenchOptions& options) {
  DistBenchOptions o = options;
  if (o.frames.empty()) {
    const std::string shared = shared_data_dir();
    if (shared.empty())
      throw Error("bench dist", "../shared/data is absent: give the sequence with --frames-of");
    o.frames = (fs::path(shared) / "anim_horse_collapse" / "frames").string();
  }
  if (!fs::exists(o.frames) && o.frames.find('%') == std::string::npos &&
      o.frames.find('*') == std::string::npos)
    throw Error(o.frames, "no such frames");
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 0);  // containers run as root; mpirun asks consent
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 0);
  const fs::path program = splitray_program();
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const fs::path work =
      fs::temp_directory_path() / fmt::format("splitray-bench-dist-{}", ::getpid());
  fs::create_directories(work);
  struct Cleanup {
    fs::path dir;
    ~Cleanup() {
      std::error_code ignored;
      fs::remove_all(dir, ignored);
    }
  } cleanup{work};

  std::vector<int> counts = {0};
  counts.insert(counts.end(), o.ranks.begin(), o.ranks.end());
  std::map<std::string, std::string> reference;
  Json rows = Json::array();
  for (const int ranks : counts) {
    std::vector<Run> runs;
    bool identical = true;
    for (int r = 0; r < o.runs; ++r) {
      fmt::print(stderr, "bench dist: {} run {}/{}\n",
                 ranks == 0 ? std::string("single process") : fmt::format("{} ranks", ranks), r + 1,
                 o.runs);
      runs.push_back(animate(program, ranks, o, work, r));
      if (reference.empty()) reference = runs.back().frames;
      identical = identical && runs.back().frames == reference;
    }
    std::vector<double> walls;
    for (const Run& run : runs) walls.push_back(run.report["wall_ms"].get<double>());
    const double wall = median(walls);
    const Run& typical =
        *std::min_element(runs.begin(), runs.end(), [&](const Run& a, const Run& b) {
          return std::abs(a.report["wall_ms"].get<double>() - wall) <
                 std::abs(b.report["wall_ms"].get<double>() - wall);
        });
    std::vector<double> compute;
    for (const Json& f : typical.report["frame_rows"])
      compute.push_back(f["load_ms"].get<double>() + f["build_ms"].get<double>() +
                        f["render_ms"].get<double>());
    double comm = 0;
    for (const Json& s : typical.report["rank_stats"])
      comm = std::max(comm, s["comm_ms"].get<double>() + s["assembly_ms"].get<double>());
    rows.push_back({{"ranks", ranks},
                    {"oversubscribed", ranks > cores},
                    {"wall_ms", wall},
                    {"frames_per_s", static_cast<double>(o.frame_count) / (wall / 1000)},
                    {"frame_compute_ms", median(compute)},
                    {"comm_and_assembly_ms", comm},
                    {"comm_share", wall > 0 ? comm / wall : 0.0},
                    {"identical_images", identical}});
  }
  const double single = rows[0]["wall_ms"].get<double>();
  double one_rank = single;
  Json one_row = rows[0];
  for (const Json& row : rows)
    if (row["ranks"].get<int>() == 1) one_rank = row["wall_ms"].get<double>(), one_row = row;
  for (Json& row : rows) {
    row["speedup_vs_single"] = single / row["wall_ms"].get<double>();
    row["speedup_vs_one_rank"] = one_rank / row["wall_ms"].get<double>();
  }
  // Every frame is independent work of about the measured compute time; rank 0 hands out runs
  // and writes every image: T(N) = F compute / N + F (comm + write) per frame, with the
  // per-frame communication at least an uncompressed RGB image over 10 Gbit/s.
  const double frame_compute = one_row["frame_compute_ms"].get<double>() > 0
                                   ? one_row["frame_compute_ms"].get<double>()
                                   : one_rank / static_cast<double>(o.frame_count);
  const double per_frame_comm =
      std::max(one_row["comm_and_assembly_ms"].get<double>() / static_cast<double>(o.frame_count),
               static_cast<double>(o.width) * o.height * 3 * 8 / 10e9 * 1000);
  constexpr double kFrames = 1000;
  Json projection = Json::array();
  for (const int nodes : {8, 16, 32, 64}) {
    const int ranks = nodes * cores;
    const double t = kFrames * frame_compute / ranks + kFrames * per_frame_comm;
    projection.push_back({{"nodes", nodes},
                          {"ranks", ranks},
                          {"frames_per_s", kFrames / (t / 1000)},
                          {"speedup_vs_one_rank", kFrames * frame_compute / t},
                          {"efficiency", kFrames * frame_compute / t / ranks}});
  }
  Json report;
  report["machine"] = machine_json(1);
  report["cores"] = cores;
  report["sequence"] = fs::path(o.frames).lexically_relative(SPLITRAY_SOURCE_DIR).string();
  report["frames"] = o.frame_count;
  report["width"] = o.width;
  report["height"] = o.height;
  report["mode"] = o.mode;
  report["runs"] = o.runs;
  report["rows"] = rows;
  report["projection"] = projection;
  report["projection_model"] = fmt::format(
      "{:.0f} frames of the measured single-thread compute ({:.0f} ms) spread over N nodes x {} "
      "ranks, plus a serial {:.1f} ms per frame at rank 0 (the larger of the measured "
      "communication + assembly and an uncompressed RGB image over 10 Gbit/s); frames assumed "
      "independent (a run of predicted rebuilds per rank), loading from a shared file system "
      "not counted.",
      kFrames, frame_compute, cores, per_frame_comm);
  return report;
}

void dist_bench_command(const DistBenchOptions& options) {
  check_output_folders({options.json.file, options.markdown_path});
  const Json report = run_dist_bench(options);
  emit_report(options.json, options.markdown_path, report, markdown(report));
}

}  // namespace splitray::bench

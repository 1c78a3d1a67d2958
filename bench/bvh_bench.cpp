#include "bvh_bench.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <optional>

#include "bench_meshes.hpp"
#include "bench_report.hpp"
#include "machine.hpp"
#include "splitray/accel/accel.hpp"
#include "splitray/accel/bvh/bvh.hpp"
#include "splitray/accel/bvh/wide_bvh_walk.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/render/ray_sets.hpp"
#include "trace_measure.hpp"

namespace splitray::bench {

namespace {

using Json = nlohmann::ordered_json;

constexpr int kDefaultRuns = 5, kQuickRuns = 1;
constexpr std::size_t kDefaultRays = 1u << 18, kQuickRays = 1u << 14;

struct Structure {
  std::string accel, builder;
  std::string label() const { return accel + " " + builder; }
};

// Ours, each beside the Embree build of the same quality (binned SAH / spatial splits); Embree
// low (Morton) is reported too, and Embree medium in its robust mode, whose conservative box
// test and Pluecker triangle test give its hits nearly the guarantee ours have (Embree builds
// robust scenes at medium quality at most, so both of ours meet that tree there).
const std::vector<Structure> kStructures = {{"bvh", "binned"},  {"bvh", "sbvh"},
                                            {"embree", "low"},  {"embree", "medium"},
                                            {"embree", "high"}, {"embree", "medium-robust"}};
const std::vector<std::pair<std::string, std::string>> kPairs = {{"binned", "medium"},
                                                                 {"sbvh", "high"}};
const std::vector<std::pair<std::string, std::string>> kRobustPairs = {{"binned", "medium-robust"},
                                                                       {"sbvh", "medium-robust"}};

struct RaySet {
  std::string kind;
  std::vector<Ray> rays;
};

// Every kind's rays, the same share from each view (seeds differ per view).
std::vector<RaySet> make_ray_sets(std::span<const Triangle> triangles,
                                  const std::vector<Camera>& views, std::size_t count,
                                  std::uint64_t seed, std::vector<std::string>& notes,
                                  const std::string& mesh) {
  std::vector<RaySet> sets;
  for (const RayKind kind : {RayKind::primary, RayKind::diffuse}) {
    RaySet set{kind == RayKind::primary ? "primary" : "diffuse", {}};
    for (std::size_t v = 0; v < views.size(); ++v) {
      const std::size_t share = count / views.size() + (v < count % views.size() ? 1 : 0);
      try {
        const std::vector<Ray> rays = make_rays(triangles, kind, seed + v, share, views[v]);
        set.rays.insert(set.rays.end(), rays.begin(), rays.end());
      } catch (const Error& e) {  // a view that sees nothing has no diffuse rays
        notes.push_back(fmt::format("{}: view {}: no {} rays: {}", mesh, v, set.kind, e.what()));
      }
    }
    if (!set.rays.empty()) sets.push_back(std::move(set));
  }
  return sets;
}

struct Built {
  Structure structure;
  std::unique_ptr<Accel> accel;
  Json row;
};

// Build rounds: at least `runs`, and for fast builds as many as take about this long for the
// slowest structure (at most kMaxBuildRounds): a build of 2-3 ms timed three times in a row
// moved by +-5% between runs, enough to turn a ratio to Embree's either way.
constexpr double kBuildRoundsMs = 200;
constexpr int kMaxBuildRounds = 25;

std::unique_ptr<Accel> build_once(const Structure& s, std::span<const Triangle> triangles,
                                  int threads) {
  BuildConfig config;
  config.builder = s.builder;
  config.threads = threads;
  return make_accel(s.accel, triangles, config);
}

Json build_row(const Structure& s, const AccelStats& stats, const std::vector<double>& build_ms) {
  return Json{{"accel", s.accel},
              {"builder", s.builder},
              {"build_ms", median(build_ms)},
              {"build_ms_runs", build_ms},
              {"sah_cost", stats.sah_cost ? Json(*stats.sah_cost) : Json(nullptr)},
              {"sah_kt", stats.sah_traversal_cost},
              {"sah_ki", stats.sah_intersection_cost},
              {"nodes", stats.nodes},
              {"prim_refs", stats.prim_refs},
              {"bytes", stats.bytes}};
}

// Builds every structure at the current thread limit: a first build each (untimed: it pays
// the first touch of the memory), then rounds in which each structure rebuilds in turn, its
// previous build freed first, so that ours and Embree's see the same state of a noisy machine
// (as trace_all does for tracing); each keeps its last build. A structure that cannot be built
// gets a row with its error.
std::vector<Built> build_all(std::span<const Triangle> triangles, int threads, int runs,
                             Json& failed) {
  std::vector<Built> built;
  std::vector<double> first_ms;
  for (const Structure& s : kStructures) {
    try {
      Built b{s, build_once(s, triangles, threads), {}};
      first_ms.push_back(b.accel->stats().build_ms);
      built.push_back(std::move(b));
    } catch (const Error& e) {
      fmt::print(stderr, "  {:<14} failed: {}\n", s.label(), e.what());
      failed.push_back(Json{{"accel", s.accel}, {"builder", s.builder}, {"error", e.what()}});
    }
  }
  const double slowest_ms =
      first_ms.empty() ? 0.0 : *std::max_element(first_ms.begin(), first_ms.end());
  const int rounds =
      std::clamp(static_cast<int>(std::ceil(kBuildRoundsMs / std::max(slowest_ms, 1e-3))), runs,
                 std::max(runs, kMaxBuildRounds));
  std::vector<std::vector<double>> ms(built.size());
  for (int r = 0; r < rounds; ++r)
    for (std::size_t b = 0; b < built.size(); ++b) {
      built[b].accel.reset();
      built[b].accel = build_once(built[b].structure, triangles, threads);
      ms[b].push_back(built[b].accel->stats().build_ms);
    }
  for (std::size_t b = 0; b < built.size(); ++b) {
    built[b].row = build_row(built[b].structure, built[b].accel->stats(), ms[b]);
    built[b].row["first_build_ms"] = first_ms[b];
    fmt::print(stderr, "  {} thread{} {:<14} build {:8.2f} ms ({} builds)\n", threads,
               threads == 1 ? " " : "s", built[b].structure.label(),
               built[b].row["build_ms"].get<double>(), rounds);
  }
  return built;
}

// Traces every set through every built structure, single-ray and batched calls: after a
// warm-up pass each, `runs` rounds in which every structure takes one timed pass in turn, so
// that ours and Embree's see the same state of a noisy machine; the medians go to each row.
// Returns each structure's batched hits per set.
std::vector<std::vector<std::vector<Hit>>> trace_all(std::vector<Built>& built,
                                                     const std::vector<RaySet>& sets, int runs) {
  std::vector<std::vector<std::vector<Hit>>> hits(built.size());
  for (auto& h : hits) h.resize(sets.size());
  for (std::size_t k = 0; k < sets.size(); ++k) {
    const std::vector<Ray>& rays = sets[k].rays;
    for (const char* mode : {"single", "batched"}) {
      const bool single = std::string(mode) == "single";
      std::vector<std::vector<Hit>> out(built.size(), std::vector<Hit>(rays.size()));
      const auto pass = [&](std::size_t b) {
        if (single)
          built[b].accel->intersect_each(rays, out[b]);
        else
          built[b].accel->intersect(rays, out[b]);
      };
      std::vector<std::vector<double>> ms(built.size());
      for (std::size_t b = 0; b < built.size(); ++b) pass(b);  // warm-up
      for (int r = 0; r < runs; ++r)
        for (std::size_t b = 0; b < built.size(); ++b) {
          Timer timer;
          pass(b);
          ms[b].push_back(timer.ms());
        }
      for (std::size_t b = 0; b < built.size(); ++b) {
        const double m = median(ms[b]);
        Json& t = built[b].row["trace"][sets[k].kind];
        t[mode] = {{"mrays_per_s", m > 0 ? static_cast<double>(rays.size()) / (m * 1000.0) : 0.0},
                   {"ms", m},
                   {"ms_runs", ms[b]}};
        if (single) {
          hits[b][k] = std::move(out[b]);
        } else {
          t["single_equals_batched"] = differing(hits[b][k], out[b]) == 0;
          const Checksum c = checksum(out[b]);
          t["hits"] = c.hits;
          t["id_checksum"] = c.id_checksum;
        }
      }
    }
  }
  return hits;
}

// What one node test and one block test of eight triangles cost (ns) with their data in the
// L1 cache, over the first rays of `rays`: the compute part of a ray's time. The rest of what a
// ray takes is the walk's control and waiting for memory.
struct UnitCosts {
  double node_ns = 0, block_ns = 0;
};

UnitCosts unit_costs(const Bvh& bvh, std::span<const Ray> all_rays) {
  constexpr int kRepeats = 256;
  const std::span<const Ray> rays = all_rays.first(std::min<std::size_t>(all_rays.size(), 512));
  if (rays.empty() || bvh.wide().nodes().empty()) return {};
  const WideNode& node = bvh.wide().nodes()[0];
  const TriangleBlock& block = bvh.wide().blocks()[0];
  std::vector<RobustRay> robust;
  std::vector<WatertightRay> watertight;
  for (const Ray& r : rays) {
    robust.emplace_back(r, bvh.bounds(), coordinate_magnitude(bvh.bounds()));
    watertight.emplace_back(r);
  }
  std::vector<wide_bvh::WideSlab> slabs;
  std::vector<wide_bvh::WatertightBlock> tests;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    slabs.emplace_back(robust[i]);
    tests.emplace_back(watertight[i]);
  }
  unsigned sink = 0;  // keeps the tests from being optimised away
  alignas(64) float t[kWideWidth], u[kBlockWidth], v[kBlockWidth];
  Timer node_timer;
  for (int k = 0; k < kRepeats; ++k)
    for (std::size_t i = 0; i < rays.size(); ++i)
      sink += slabs[i].test(node, rays[i].tmin, rays[i].tmax, t);
  const double node_ms = node_timer.ms();
  Timer block_timer;
  for (int k = 0; k < kRepeats; ++k)
    for (std::size_t i = 0; i < rays.size(); ++i) {
      unsigned scalar = 0;
      sink += tests[i].test(block, rays[i].tmin, rays[i].tmax, t, u, v, scalar) + scalar;
    }
  const double block_ms = block_timer.ms();
  const double tests_done = static_cast<double>(kRepeats) * static_cast<double>(rays.size());
  if (sink == 1) fmt::print(stderr, " ");  // almost never; the compiler cannot know
  return {node_ms * 1e6 / tests_done, block_ms * 1e6 / tests_done};
}

// What a ray loses to being new to the CPU: mispredicted branches, and cache misses, which this
// machine has no counters for. The single-ray call's time per ray (ns, median of kRuns) over
// distinct rays, and over the same rays each traced kRepeats times in a row, whose walk the
// branch predictor and the caches have then learned. The rays: 64 runs of 128 consecutive rays
// spread over the set (neighbouring pixels stay neighbours, every view is sampled).
struct FirstWalk {
  double distinct_ns = 0, repeated_ns = 0;
};

constexpr std::size_t kFirstWalkRuns = 64, kFirstWalkRun = 128;

std::vector<Ray> first_walk_rays(std::span<const Ray> all) {
  if (all.size() <= kFirstWalkRuns * kFirstWalkRun) return {all.begin(), all.end()};
  std::vector<Ray> rays;
  const std::size_t stride = all.size() / kFirstWalkRuns;
  for (std::size_t r = 0; r < kFirstWalkRuns; ++r)
    rays.insert(rays.end(), all.begin() + static_cast<std::ptrdiff_t>(r * stride),
                all.begin() + static_cast<std::ptrdiff_t>(r * stride + kFirstWalkRun));
  return rays;
}

FirstWalk first_walk(const Accel& accel, std::span<const Ray> rays) {
  constexpr int kRepeats = 8, kRuns = 5;
  if (rays.empty()) return {};
  std::uint64_t sink = 0;  // keeps the calls from being optimised away
  std::vector<double> distinct, repeated;
  for (int run = 0; run < kRuns; ++run) {
    Timer once;
    for (const Ray& ray : rays) sink += accel.intersect(ray).prim;
    distinct.push_back(once.ms());
    Timer again;
    for (const Ray& ray : rays)
      for (int k = 0; k < kRepeats; ++k) sink += accel.intersect(ray).prim;
    repeated.push_back(again.ms() / kRepeats);
  }
  if (sink == 1) fmt::print(stderr, " ");  // almost never; the compiler cannot know
  const auto ns = [&](std::vector<double>& ms) {
    std::nth_element(ms.begin(), ms.begin() + kRuns / 2, ms.end());
    return ms[kRuns / 2] * 1e6 / static_cast<double>(rays.size());
  };
  return {ns(distinct), ns(repeated)};
}

// What a ray costs in our wide layout, averaged over every ray of each set (one thread: the
// counts do not depend on it), and the compute part of it (unit_costs); and what a new ray
// loses in our single-ray call and in Embree's of the same quality (`theirs`; first_walk).
Json traversal_profile(const std::string& builder, const std::string& theirs,
                       std::span<const Triangle> triangles, const std::vector<RaySet>& sets) {
  BuildConfig config;
  config.builder = builder;
  const Bvh bvh = Bvh::build(triangles, builder, BvhBuildOptions::from(config));
  const std::size_t node_bytes = sizeof(WideNode), block_bytes = sizeof(TriangleBlock);
  const UnitCosts unit = unit_costs(bvh, sets.empty() ? std::span<const Ray>{} : sets[0].rays);
  Json profile{{"builder", builder},           {"wide_nodes", bvh.wide().nodes().size()},
               {"node_bytes", node_bytes},     {"block_bytes", block_bytes},
               {"node_test_ns", unit.node_ns}, {"block_test_ns", unit.block_ns}};
  BuildConfig embree_config;
  embree_config.builder = theirs;
  const std::unique_ptr<Accel> ours = make_accel("bvh", triangles, config);
  const std::unique_ptr<Accel> embree = make_accel("embree", triangles, embree_config);
  for (const RaySet& set : sets) {
    const std::vector<Ray> sample = first_walk_rays(set.rays);
    const FirstWalk our_walk = first_walk(*ours, sample);
    const FirstWalk embree_walk = first_walk(*embree, sample);
    WideBvhCounts counts;
    for (const Ray& ray : set.rays) bvh.intersect_counted(ray, counts);
    const auto per_ray = [&](std::uint64_t n) {
      return static_cast<double>(n) / static_cast<double>(std::max<std::uint64_t>(counts.rays, 1));
    };
    profile[set.kind] = {
        {"nodes_per_ray", per_ray(counts.nodes)},
        {"boxes_per_ray", per_ray(counts.boxes)},
        {"leaves_per_ray", per_ray(counts.leaves)},
        {"blocks_per_ray", per_ray(counts.blocks)},
        {"hit_leaves_per_hit", static_cast<double>(counts.hit_leaves) /
                                   static_cast<double>(std::max<std::uint64_t>(counts.hits, 1))},
        {"late_leaves_per_ray", per_ray(counts.late_leaves)},
        {"triangle_lanes_per_ray", per_ray(counts.blocks * kBlockWidth)},
        {"bytes_per_ray", per_ray(counts.nodes * node_bytes + counts.blocks * block_bytes)},
        {"compute_ns_per_ray",
         per_ray(counts.nodes) * unit.node_ns + per_ray(counts.blocks) * unit.block_ns},
        {"first_walk",
         {{"rays", sample.size()},
          {"ours_distinct_ns", our_walk.distinct_ns},
          {"ours_repeated_ns", our_walk.repeated_ns},
          {"embree", "embree " + theirs},
          {"embree_distinct_ns", embree_walk.distinct_ns},
          {"embree_repeated_ns", embree_walk.repeated_ns}}}};
  }
  return profile;
}

// What a ray costs before its walk: rays that cannot meet the mesh (the directions of `set`,
// started outside the scene's box and pointing away from it), in ns per ray on one thread
// (median of `runs`): our binned BVH's single-ray and batched calls, and Embree medium's
// (rtcIntersect1, rtcIntersect8). Embree's packets test the root once for eight rays.
Json fixed_cost(std::span<const Triangle> triangles, const RaySet& set, int runs) {
  Aabb box;
  for (const Triangle& t : triangles) box.extend(t.bounds());
  const Vec3 centre = box.center();
  const float reach = 2 * length(box.extent()) + 1;
  std::vector<Ray> rays;
  rays.reserve(set.rays.size());
  for (const Ray& r : set.rays) {
    const Vec3 d = normalize(r.dir);
    rays.push_back(Ray{centre + d * reach, d});
  }
  const ThreadLimit one(1);
  BuildConfig config;
  config.builder = "binned";
  const std::unique_ptr<Accel> ours = make_accel("bvh", triangles, config);
  config.builder = "medium";
  const std::unique_ptr<Accel> embree = make_accel("embree", triangles, config);
  std::vector<Hit> hits(rays.size());
  std::uint64_t found = 0;
  const auto ns = [&](const std::function<void()>& pass) {
    const Json t = throughput(rays.size(), runs, pass);
    for (const Hit& h : hits) found += h.found() ? 1 : 0;
    return t["ms"].get<double>() * 1e6 / static_cast<double>(std::max<std::size_t>(rays.size(), 1));
  };
  Json out{{"rays", rays.size()},
           {"ours_single_ns", ns([&] { ours->intersect_each(rays, hits); })},
           {"ours_batched_ns", ns([&] { ours->intersect(rays, hits); })},
           {"embree_single_ns", ns([&] { embree->intersect_each(rays, hits); })},
           {"embree_batched_ns", ns([&] { embree->intersect(rays, hits); })}};
  if (found != 0) throw Error("bench bvh", "a ray aimed away from the mesh hit it");
  return out;
}

const Json* find_row(const Json& rows, const std::string& accel, const std::string& builder) {
  for (const Json& row : rows)
    if (row["accel"] == accel && row["builder"] == builder && !row.contains("error")) return &row;
  return nullptr;
}

// Ours over Embree's of the same quality, from the same run: build time (lower is better)
// and every Mrays/s (higher is better); `pairs` names Embree's builder beside each of ours.
Json ratios(const Json& rows, const std::vector<std::pair<std::string, std::string>>& pairs) {
  Json out = Json::object();
  for (const auto& [ours, theirs] : pairs) {
    const Json* a = find_row(rows, "bvh", ours);
    const Json* b = find_row(rows, "embree", theirs);
    if (!a || !b) continue;
    Json r{{"against", "embree " + theirs},
           {"build", (*a)["build_ms"].get<double>() / (*b)["build_ms"].get<double>()}};
    for (const auto& [kind, t] : (*a)["trace"].items())
      for (const char* mode : {"single", "batched"})
        r[kind][mode] = t[mode]["mrays_per_s"].get<double>() /
                        (*b)["trace"][kind][mode]["mrays_per_s"].get<double>();
    out[ours] = r;
  }
  return out;
}

std::vector<int> thread_counts(const BvhBenchOptions& options) {
  std::vector<int> counts = options.threads;
  if (counts.empty()) counts = {1, hardware_threads()};
  for (int& t : counts)
    if (t <= 0) t = hardware_threads();
  std::sort(counts.begin(), counts.end());
  counts.erase(std::unique(counts.begin(), counts.end()), counts.end());
  return counts;
}

// The table of our Mrays/s over Embree's for each mesh, thread count, kind and call, from the
// ratios under `key` of every run, with the count of cells at or above 1.0.
std::string tracing_table(const Json& report, const std::string& key) {
  std::string md =
      "| mesh | triangles | threads | kind | binned single | binned batched | sbvh single | sbvh "
      "batched |\n|---|--:|--:|---|--:|--:|--:|--:|\n";
  int cells = 0, met = 0;
  double worst = 1e9;
  const auto cell = [&](const Json& r, const std::string& b, const std::string& kind,
                        const char* mode) -> std::string {
    if (!r.contains(b) || !r[b].contains(kind)) return "–";
    const double v = r[b][kind][mode].get<double>();
    ++cells;
    met += v >= 1.0 ? 1 : 0;
    worst = std::min(worst, v);
    return fmt::format("{:.2f}×", v);
  };
  for (const Json& mesh : report["meshes"])
    for (const Json& run : mesh["runs"]) {
      if (!run.contains(key)) continue;
      for (const char* kind : {"primary", "diffuse"})
        md += fmt::format(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n", mesh["name"].get<std::string>(),
            mesh["triangles"].get<std::size_t>(), run["threads"].get<int>(), kind,
            cell(run[key], "binned", kind, "single"), cell(run[key], "binned", kind, "batched"),
            cell(run[key], "sbvh", kind, "single"), cell(run[key], "sbvh", kind, "batched"));
    }
  md += fmt::format("\nAt or above 1.0×: {} of {} cells (lowest {:.2f}×).\n\n", met, cells,
                    cells > 0 ? worst : 0.0);
  return md;
}

}  // namespace

void add_bvh_bench_options(CLI::App& command, BvhBenchOptions& options) {
  command
      .add_option("--runs", options.runs,
                  "Timed runs per measurement; the median is reported (default 5, --quick 1; "
                  "fast builds take more rounds, up to 25)")
      ->check(CLI::PositiveNumber);
  command
      .add_option("--rays", options.rays,
                  "Rays per kind over all views (default 262144, --quick 16384)")
      ->check(CLI::Range(std::size_t{1}, std::size_t{1} << 26));
  command.add_option(
      "--meshes", options.meshes,
      "Benchmark meshes by name (horse, dragon, sibenik, ...) or mesh files, each optionally with "
      "@EX,EY,EZ,TX,TY,TZ[,FOV], the camera to measure from (e.g. inside a room: "
      "conference.obj@1300,400,-200,0,150,-200,75); default: all present");
  command
      .add_option("--threads", options.threads,
                  "Thread counts to measure at (0 = all cores; default: 1 and all cores)")
      ->check(CLI::Range(0, 65536));
  command
      .add_option("--views", options.views,
                  "Viewpoints per mesh: the camera turned about its up axis in equal steps, "
                  "about the eye inside a mesh's bounds, else about the target (default 4)")
      ->check(CLI::Range(1, 64));
  command.add_option("--seed", options.seed, "Seed of the ray sets");
  command.add_flag("--quick", options.quick,
                   "Smoke test: the two vendored meshes (unless --meshes), 1 run, 16384 rays");
  cli::add_json_options(command, options.json, "the full report");
  command.add_option("--markdown", options.markdown_path,
                     "Write the Markdown tables to this file (default: print them)");
}

Json run_bvh_bench(const BvhBenchOptions& options) {
  const int runs = options.runs > 0 ? options.runs : (options.quick ? kQuickRuns : kDefaultRuns);
  const std::size_t ray_count =
      options.rays > 0 ? options.rays : (options.quick ? kQuickRays : kDefaultRays);
  const std::vector<int> threads = thread_counts(options);
  std::vector<std::string> notes;
  const std::vector<BenchMesh> meshes = select_meshes(
      benchmark_meshes(options.quick && options.meshes.empty(), notes), options.meshes);

  Json report;
  report["benchmark"] = "bvh";
  report["machine"] = machine_json(threads.back());
  report["settings"] = {
      {"runs", runs},
      {"rays_per_kind", ray_count},
      {"views", options.views},
      {"threads", threads},
      {"seed", options.seed},
      {"kinds", {"primary", "diffuse"}},
      {"pairs", {{"binned", "embree medium"}, {"sbvh", "embree high"}}},
      {"robust_pairs", {{"binned", "embree medium-robust"}, {"sbvh", "embree medium-robust"}}},
      {"single", "Accel::intersect_each (Embree: rtcIntersect1)"},
      {"batched", "Accel::intersect (Embree: rtcIntersect8 packets)"},
      {"quick", options.quick}};
  Json mesh_reports = Json::array();
  for (std::size_t m = 0; m < meshes.size(); ++m) {
    const BenchMesh& mesh = meshes[m];
    std::vector<Triangle> triangles;
    try {
      triangles = load_mesh(mesh.path).triangles();
    } catch (const Error& e) {
      notes.push_back(mesh.name + ": " + e.what());
      fmt::print(stderr, "[{}/{}] {}: cannot load: {}\n", m + 1, meshes.size(), mesh.name,
                 e.what());
      continue;
    }
    Aabb bounds;
    for (const Triangle& t : triangles) bounds.extend(t.bounds());
    const Camera camera = mesh.camera ? *mesh.camera : fit_camera(triangles);
    const std::vector<Camera> views = turned_views(camera, options.views, bounds);
    fmt::print(stderr, "[{}/{}] {} ({} triangles, {}, {} views)\n", m + 1, meshes.size(), mesh.name,
               triangles.size(), mesh.view, views.size());
    Json mr{{"name", mesh.name}, {"path", report_path(mesh.path)}, {"triangles", triangles.size()}};
    mr["views"] = Json::array();
    for (const Camera& v : views)
      mr["views"].push_back(camera_json(v, bounds.contains(v.eye) ? "inside" : "outside"));
    const std::vector<RaySet> sets =
        make_ray_sets(triangles, views, ray_count, options.seed, notes, mesh.name);

    Json per_threads = Json::array();
    for (const int t : threads) {
      const ThreadLimit limit(t);
      Json rows = Json::array();
      std::vector<Built> built = build_all(triangles, t, runs, rows);
      const auto hits = trace_all(built, sets, runs);
      std::optional<std::size_t> binned, sbvh;
      for (std::size_t b = 0; b < built.size(); ++b) {
        const Structure& s = built[b].structure;
        std::string line = fmt::format("  {} thread{} {:<14}", t, t == 1 ? " " : "s", s.label());
        for (auto& [kind, tr] : built[b].row["trace"].items())
          line +=
              fmt::format("  {} {:6.2f}/{:6.2f}", kind, tr["single"]["mrays_per_s"].get<double>(),
                          tr["batched"]["mrays_per_s"].get<double>());
        fmt::print(stderr, "{} Mrays/s (single/batched)\n", line);
        if (s.accel == "bvh") (s.builder == "binned" ? binned : sbvh) = b;
        rows.push_back(std::move(built[b].row));
      }
      // Both of ours are exact (watertight test, one tie rule), so they must agree on every ray.
      Json agree = Json::object();
      if (binned && sbvh)
        for (std::size_t k = 0; k < sets.size(); ++k)
          agree[sets[k].kind] = differing(hits[*binned][k], hits[*sbvh][k]);
      per_threads.push_back({{"threads", t},
                             {"results", rows},
                             {"ratios", ratios(rows, kPairs)},
                             {"ratios_robust", ratios(rows, kRobustPairs)},
                             {"binned_vs_sbvh_differing", agree}});
    }
    mr["runs"] = per_threads;
    Json profile = Json::array();
    for (const auto& pair : kPairs) {
      Json p = traversal_profile(pair.first, pair.second, triangles, sets);
      // Beside it, what a ray took in the single-ray call on one thread, when measured.
      for (const Json& run : per_threads) {
        if (run["threads"] != 1) continue;
        const Json* row = find_row(run["results"], "bvh", pair.first);
        for (const RaySet& set : sets) {
          if (!row || !p.contains(set.kind)) continue;
          const double ns = (*row)["trace"][set.kind]["single"]["ms"].get<double>() * 1e6 /
                            static_cast<double>(set.rays.size());
          p[set.kind]["measured_ns_per_ray"] = ns;
          p[set.kind]["compute_share"] = p[set.kind]["compute_ns_per_ray"].get<double>() / ns;
        }
      }
      profile.push_back(std::move(p));
    }
    mr["profile"] = profile;
    if (!sets.empty()) mr["fixed_cost"] = fixed_cost(triangles, sets.back(), runs);
    mesh_reports.push_back(std::move(mr));
  }
  report["meshes"] = mesh_reports;
  report["machine"]["load_average_end"] = load_average();
  report["notes"] = notes;
  return report;
}

std::string bvh_markdown(const Json& report) {
  std::string md;
  const Json& machine = report["machine"];
  md += fmt::format(
      "BVH against Embree {} on {} ({} hardware threads), {} runs (medians), {} rays per kind "
      "over {} views, {}; load average {:.1f} -> {:.1f}.\n\n",
      machine.value("embree", "?"), machine.value("cpu", "?"), machine.value("hardware_threads", 0),
      report["settings"]["runs"].get<int>(), report["settings"]["rays_per_kind"].get<std::size_t>(),
      report["settings"]["views"].get<int>(), machine.value("date_utc", ""),
      machine.value("load_average_start", -1.0), machine.value("load_average_end", -1.0));

  md +=
      "**Tracing**: ours / Embree's Mrays/s (binned / medium, sbvh / high), single-ray calls and "
      "batched calls, same rays, same run.\n\n";
  md += tracing_table(report, "ratios");
  md +=
      "**Tracing against Embree's robust mode** (`RTC_SCENE_FLAG_ROBUST`: conservative box tests "
      "and a triangle test no ray aimed at an edge passes through, the guarantee nearest to ours; "
      "binned and sbvh / medium-robust, the best tree Embree builds in that mode), the same rays "
      "in the same run.\n\n";
  md += tracing_table(report, "ratios_robust");

  md +=
      "**Builds**: median ms of the builds taken in turns (at least --runs rounds, more for fast "
      "builds), ours over Embree's of the same quality (≤ 1.0× is the target), and the SAH cost "
      "of our trees (K_T 15, K_I 20).\n\n";
  md +=
      "| mesh | threads | binned ms | Embree medium ms | ratio | sbvh ms | Embree high ms | "
      "ratio | Embree low ms | SAH binned | SAH sbvh "
      "|\n|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n";
  for (const Json& mesh : report["meshes"])
    for (const Json& run : mesh["runs"]) {
      const auto ms = [&](const std::string& accel, const std::string& builder) -> std::string {
        const Json* row = find_row(run["results"], accel, builder);
        return row ? fmt::format("{:.1f}", (*row)["build_ms"].get<double>()) : "–";
      };
      const auto sah = [&](const std::string& builder) -> std::string {
        const Json* row = find_row(run["results"], "bvh", builder);
        return row && !(*row)["sah_cost"].is_null()
                   ? fmt::format("{:.1f}", (*row)["sah_cost"].get<double>())
                   : "–";
      };
      const auto ratio = [&](const std::string& b) -> std::string {
        return run["ratios"].contains(b)
                   ? fmt::format("{:.2f}×", run["ratios"][b]["build"].get<double>())
                   : "–";
      };
      md += fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
                        mesh["name"].get<std::string>(), run["threads"].get<int>(),
                        ms("bvh", "binned"), ms("embree", "medium"), ratio("binned"),
                        ms("bvh", "sbvh"), ms("embree", "high"), ratio("sbvh"), ms("embree", "low"),
                        sah("binned"), sah("sbvh"));
    }

  md +=
      "\n**What a ray costs in our wide layout** (per ray: wide nodes visited, child boxes "
      "tested, leaves entered, blocks of eight triangles tested, bytes of nodes and blocks read; "
      "per ray that hits, the leaves entered that hold the triangle of its closest hit (more than "
      "one where spatial splits put it in several leaves), and per ray the leaves entered after "
      "that hit was found; "
      "the time of our single-ray call on one thread, and what its node and block tests take "
      "with their data in the L1 cache: the rest is waiting for memory and the walk's "
      "control. Then what a ray new to the CPU loses, this machine having no counters of "
      "mispredicted branches and cache misses: ns per ray of our single-ray call and of "
      "Embree's of the same quality over 8192 distinct rays (64 runs of 128 consecutive rays "
      "spread over the set), and over the same rays each traced 8 times in a row, whose walks the "
      "branch predictor and the caches have then learned).\n\n";
  md +=
      "| mesh | builder | kind | nodes | boxes | leaves | blocks | bytes | leaves with the hit | "
      "leaves after it | ns per ray | of which node and block tests | ours: distinct / repeated "
      "ns | Embree: distinct / repeated ns |\n|---|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|"
      "--:|--:|\n";
  for (const Json& mesh : report["meshes"])
    for (const Json& p : mesh["profile"])
      for (const char* kind : {"primary", "diffuse"}) {
        if (!p.contains(kind)) continue;
        const Json& k = p[kind];
        const std::string measured =
            k.contains("measured_ns_per_ray")
                ? fmt::format("{:.0f} | {:.0f} ({:.0f}%)", k["measured_ns_per_ray"].get<double>(),
                              k["compute_ns_per_ray"].get<double>(),
                              100 * k["compute_share"].get<double>())
                : fmt::format("– | {:.0f}", k["compute_ns_per_ray"].get<double>());
        const Json& f = k["first_walk"];
        md += fmt::format(
            "| {} | {} | {} | {:.1f} | {:.1f} | {:.1f} | {:.1f} | {:.0f} | {:.2f} | {:.2f} | {} | "
            "{:.0f} / {:.0f} | {:.0f} / {:.0f} |\n",
            mesh["name"].get<std::string>(), p["builder"].get<std::string>(), kind,
            k["nodes_per_ray"].get<double>(), k["boxes_per_ray"].get<double>(),
            k["leaves_per_ray"].get<double>(), k["blocks_per_ray"].get<double>(),
            k["bytes_per_ray"].get<double>(), k["hit_leaves_per_hit"].get<double>(),
            k["late_leaves_per_ray"].get<double>(), measured, f["ours_distinct_ns"].get<double>(),
            f["ours_repeated_ns"].get<double>(), f["embree_distinct_ns"].get<double>(),
            f["embree_repeated_ns"].get<double>());
      }
  md +=
      "\n**What a ray costs before its walk** (rays that cannot meet the mesh: the diffuse rays' "
      "directions, started outside the scene's box and pointing away from it; ns per ray on one "
      "thread): our binned BVH's single-ray and batched calls, Embree medium's `rtcIntersect1` "
      "and `rtcIntersect8` (whose packets test the root once for eight rays).\n\n"
      "| mesh | ours single | ours batched | Embree single | Embree batched |\n"
      "|---|--:|--:|--:|--:|\n";
  for (const Json& mesh : report["meshes"]) {
    if (!mesh.contains("fixed_cost")) continue;
    const Json& f = mesh["fixed_cost"];
    md +=
        fmt::format("| {} | {:.1f} | {:.1f} | {:.1f} | {:.1f} |\n", mesh["name"].get<std::string>(),
                    f["ours_single_ns"].get<double>(), f["ours_batched_ns"].get<double>(),
                    f["embree_single_ns"].get<double>(), f["embree_batched_ns"].get<double>());
  }
  if (!report["notes"].empty()) {
    md += "\nNotes:\n";
    for (const Json& note : report["notes"]) md += "- " + note.get<std::string>() + "\n";
  }
  return md;
}

int bvh_bench_command(const BvhBenchOptions& options) {
  check_output_folders({options.json.file, options.markdown_path});
  const Json report = run_bvh_bench(options);
  emit_report(options.json, options.markdown_path, report, bvh_markdown(report));
  if (!options.json.file.empty()) fmt::print(stderr, "wrote {}\n", options.json.file);
  if (!options.markdown_path.empty()) fmt::print(stderr, "wrote {}\n", options.markdown_path);
  for (const Json& mesh : report["meshes"])
    for (const Json& run : mesh["runs"])
      for (const auto& [kind, n] : run["binned_vs_sbvh_differing"].items())
        if (n.get<std::size_t>() != 0) {
          fmt::print(stderr, "splitray: {}: binned and sbvh disagree on {} {} rays\n",
                     mesh["name"].get<std::string>(), n.get<std::size_t>(), kind);
          return 1;
        }
  return 0;
}

}  // namespace splitray::bench

#include "neural_bench.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "bench_meshes.hpp"
#include "bench_report.hpp"
#include "machine.hpp"
#include "splitray/accel/accel.hpp"
#include "splitray/accel/neural/model_path.hpp"
#include "splitray/accel/neural/neural_accel.hpp"
#include "splitray/accel/neural/neural_model.hpp"
#include "splitray/accel/neural/neural_sampling.hpp"
#include "splitray/accel/neural/neural_top.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/image.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/query/neural_point_build.hpp"
#include "splitray/query/point_tree.hpp"
#include "splitray/query/surface_sampling.hpp"
#include "splitray/render/data_dir.hpp"
#include "splitray/render/ray_sets.hpp"

namespace splitray::bench {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

constexpr int kDefaultRuns = 5, kQuickRuns = 1;
constexpr std::size_t kDefaultRays = 1u << 18, kQuickRays = 1u << 14;
constexpr std::size_t kDefaultPoints = 1000000, kQuickPoints = 50000;
constexpr std::size_t kDefaultQueries = 200000, kQuickQueries = 10000;
// The training meshes; models/README.md may name more (read below).
const std::vector<std::string> kTrainingMeshes = {"horse", "cat", "lion", "elephant", "samba"};

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// The sections of models/README.md under a heading that mentions training ("" if none).
std::string training_text(const std::string& readme) {
  std::istringstream in(readme);
  std::string line, out;
  bool inside = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] == '#') inside = lower(line).find("train") != std::string::npos;
    if (inside) out += lower(line) + "\n";
  }
  return out;
}

// The dataset folder of a shared mesh ("static_sibenik") or the file name of another.
std::vector<std::string> mesh_keys(const BenchMesh& mesh, const std::string& shared) {
  std::vector<std::string> keys;
  const fs::path p(mesh.path);
  std::string file = p.filename().string();
  if (file.size() > 3 && file.ends_with(".gz")) file.resize(file.size() - 3);
  keys.push_back(lower(file));
  if (!shared.empty()) {
    const fs::path rel = p.lexically_relative(shared);
    if (!rel.empty() && *rel.begin() != "..") keys.push_back(lower(rel.begin()->string()));
  }
  return keys;
}

struct ModelInfo {  // NOLINT(bugprone-exception-escape): nlohmann's Json members
  std::string path;
  std::optional<NeuralModel> model;
  Json json;
};

ModelInfo model_info(const std::string& given, NeuralCost cost, std::vector<std::string>& notes) {
  ModelInfo info;
  const char* name = cost == NeuralCost::sah ? "sah" : "vvh";
  info.path = given.empty() ? find_default_model(cost) : given;
  if (info.path.empty()) {
    std::string looked;
    for (const std::string& d : model_dirs()) looked += (looked.empty() ? "" : ", ") + d;
    notes.push_back(
        fmt::format("the shipped model {}.bin is ABSENT (looked in: {}): no {} results; "
                    "train it (splitray train) or pass --{}-model FILE",
                    name, looked, cost == NeuralCost::sah ? "ray-tracing" : "k-NN", name));
    info.json = Json{{"path", nullptr}, {"absent", true}};
    return info;
  }
  try {
    info.model = load_neural_model(info.path, cost);
  } catch (const Error& e) {
    notes.push_back(std::string("model unusable: ") + e.what());
    info.json = Json{{"path", info.path}, {"error", e.what()}};
    return info;
  }
  std::size_t params = 0;
  for (const LevelEncoder& level : info.model->levels)
    for (const auto* layers : {&level.point_layers, &level.head_layers})
      for (const DenseLayer& l : *layers) params += l.weight.size() + l.bias.size();
  info.json = Json{{"path", info.path},
                   {"depth", info.model->depth()},
                   {"points", info.model->points},
                   {"pooling", info.model->pooling == NeuralPooling::max ? "max" : "mean"},
                   {"parameters", params}};
  const Json meta = Json::parse(info.model->metadata, nullptr, false);
  info.json["metadata"] = meta.is_discarded() ? Json(info.model->metadata) : meta;
  return info;
}

bool same_hits(std::span<const Hit> a, std::span<const Hit> b) {
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].prim != b[i].prim ||
        std::bit_cast<std::uint32_t>(a[i].t) != std::bit_cast<std::uint32_t>(b[i].t))
      return false;
  return true;
}

// Alternates the two measurements run by run (after a warm-up of each), so that load on the
// shared machine hits both alike; returns their median ms.
template <typename A, typename B>
std::pair<double, double> paired_ms(int runs, const A& a, const B& b) {
  a();
  b();
  std::vector<double> ta, tb;
  for (int r = 0; r < runs; ++r) {
    Timer t1;
    a();
    ta.push_back(t1.ms());
    Timer t2;
    b();
    tb.push_back(t2.ms());
  }
  return {median(ta), median(tb)};
}

Json tree_json(const AccelStats& s) {
  Json j{{"builder", s.builder},
         {"build_ms", s.build_ms},
         {"sah_cost", s.sah_cost ? Json(*s.sah_cost) : Json(nullptr)},
         // The constants sah_cost was computed with (kd's own defaults, or the BVH's).
         {"sah_kt", s.sah_cost ? Json(s.sah_traversal_cost) : Json(nullptr)},
         {"sah_ki", s.sah_cost ? Json(s.sah_intersection_cost) : Json(nullptr)},
         {"nodes", s.nodes},
         {"leaves", s.leaves},
         {"max_depth", s.max_depth},
         {"prim_refs", s.prim_refs}};
  if (s.inference_ms) j["inference_ms"] = *s.inference_ms;
  if (s.top_depth) j["top_depth"] = *s.top_depth;
  return j;
}

struct RaySet {
  std::string kind;
  std::vector<Ray> rays;
};

// B alone against neural + B on one mesh.
Json compare_triangles(const std::string& accel, const std::string& expand,
                       const std::string& model, std::span<const Triangle> triangles,
                       const std::vector<RaySet>& sets, int runs, bool& identical) {
  BuildConfig base;
  base.builder = expand;
  BuildConfig neural;
  neural.builder = "neural";
  neural.neural.model = model;
  neural.neural.expand = expand;
  std::unique_ptr<Accel> a, b;
  std::vector<double> build_a, build_b;
  for (int r = 0; r < runs; ++r) {  // alternated, one tree alive per build
    a.reset();
    a = make_accel(accel, triangles, base);
    build_a.push_back(a->stats().build_ms);
    b.reset();
    b = make_accel(accel, triangles, neural);
    build_b.push_back(b->stats().build_ms);
  }
  Json row{{"accel", accel}, {"expand", expand}};
  row["base"] = tree_json(a->stats());
  row["neural"] = tree_json(b->stats());
  row["base"]["build_ms"] = median(build_a);
  row["neural"]["build_ms"] = median(build_b);
  const double ca = a->stats().sah_cost.value_or(0), cb = b->stats().sah_cost.value_or(0);
  row["cost_ratio"] = ca > 0 ? cb / ca : 0.0;
  {  // paper 003 Fig. 3's baseline: the top greedy on the same samples, expanded alike
    BuildConfig greedy = neural;
    greedy.neural.greedy_top = true;
    const AccelStats g = make_accel(accel, triangles, greedy)->stats();
    row["greedy_top"] = tree_json(g);
    row["greedy_top_cost_ratio"] = ca > 0 ? g.sah_cost.value_or(0) / ca : 0.0;
  }
  row["build_ratio"] = median(build_b) / std::max(1e-9, median(build_a));
  Json trace = Json::object();
  for (const RaySet& set : sets) {
    std::vector<Hit> ha(set.rays.size()), hb(set.rays.size());
    const auto [ma, mb] = paired_ms(
        runs, [&] { a->intersect(set.rays, ha); }, [&] { b->intersect(set.rays, hb); });
    const bool same = same_hits(ha, hb);
    identical = identical && same;
    const double ra = static_cast<double>(set.rays.size()) / (ma * 1000.0);
    const double rb = static_cast<double>(set.rays.size()) / (mb * 1000.0);
    trace[set.kind] = Json{{"base_mrays_per_s", ra},
                           {"neural_mrays_per_s", rb},
                           {"ratio", rb / ra},
                           {"hits_identical", same}};
  }
  row["trace"] = trace;
  return row;
}

bool same_knn(const KnnResult& a, const KnnResult& b) {
  return a.indices == b.indices && a.distances == b.distances;
}

Json compare_points(const std::string& expand, const std::string& model,
                    std::span<const Vec3> points, std::span<const Vec3> queries,
                    const std::vector<int>& ks, int runs, bool& identical) {
  PointTreeConfig base;
  base.builder = expand;
  PointTreeConfig neural;
  neural.builder = "neural";
  neural.neural.model = model;
  neural.neural.expand = expand;
  std::unique_ptr<PointTree> a, b;
  std::vector<double> build_a, build_b;
  for (int r = 0; r < runs; ++r) {
    a.reset();
    a = std::make_unique<PointTree>(points, base);
    build_a.push_back(a->build_ms());
    b.reset();
    b = std::make_unique<PointTree>(points, neural);
    build_b.push_back(b->build_ms());
  }
  const PointTreeStats sa = a->stats(), sb = b->stats();
  Json row{{"structure", "points"}, {"expand", expand}};
  row["base"] = Json{{"builder", expand},
                     {"build_ms", median(build_a)},
                     {"vvh_cost", sa.vvh_cost},
                     {"nodes", sa.nodes},
                     {"max_depth", sa.max_depth}};
  row["neural"] =
      Json{{"builder", "neural+" + expand}, {"build_ms", median(build_b)},
           {"vvh_cost", sb.vvh_cost},       {"nodes", sb.nodes},
           {"max_depth", sb.max_depth},     {"inference_ms", sb.inference_ms.value_or(0)},
           {"top_depth", sb.top_depth}};
  row["cost_ratio"] = sb.vvh_cost / sa.vvh_cost;
  {  // paper 003 Fig. 3's baseline: the top greedy on the same samples, expanded alike
    PointTreeConfig greedy = neural;
    greedy.neural.greedy_top = true;
    const PointTreeStats g = PointTree(points, greedy).stats();
    row["greedy_top"] = Json{{"builder", "greedy-top+" + expand}, {"vvh_cost", g.vvh_cost}};
    row["greedy_top_cost_ratio"] = g.vvh_cost / sa.vvh_cost;
  }
  row["build_ratio"] = median(build_b) / std::max(1e-9, median(build_a));
  row["knn"] = Json::array();
  for (const int k : ks) {
    if (static_cast<std::size_t>(k) > points.size()) continue;
    KnnResult ka, kb;
    const auto [ma, mb] = paired_ms(
        runs, [&] { ka = a->knn(queries, k); }, [&] { kb = b->knn(queries, k); });
    const bool same = same_knn(ka, kb);
    identical = identical && same;
    const double qa = static_cast<double>(queries.size()) / (ma / 1000.0);
    const double qb = static_cast<double>(queries.size()) / (mb / 1000.0);
    row["knn"].push_back(Json{{"k", k},
                              {"base_queries_per_s", qa},
                              {"neural_queries_per_s", qb},
                              {"ratio", qb / qa},
                              {"neighbors_identical", same}});
  }
  return row;
}

// Progress text of a row's speed ratios: "primary x0.99 (identical), diffuse x1.01 (...)" for
// the ray kinds, "k=1 x1.02 (identical), ..." for the k-NN queries.
std::string ratios(const Json& measured) {
  std::string text;
  const auto add = [&](const std::string& name, const Json& m) {
    const bool same = m.value("hits_identical", m.value("neighbors_identical", false));
    text += fmt::format("{}{} speed x{:.3f} ({})", text.empty() ? "" : ", ", name,
                        m.value("ratio", 0.0), same ? "identical" : "DIFFERENT");
  };
  if (measured.is_array())
    for (const Json& m : measured) add("k=" + std::to_string(m.value("k", 0)), m);
  else
    for (const auto& [kind, m] : measured.items()) add(kind, m);
  return text;
}

// Triangles of about `count`: every s-th of the mesh, or copies of it side by side.
std::vector<Triangle> resized(std::span<const Triangle> mesh, std::size_t count) {
  std::vector<Triangle> out;
  out.reserve(count);
  if (count <= mesh.size()) {
    for (std::size_t i = 0; i < count; ++i) out.push_back(mesh[i * mesh.size() / count]);
    return out;
  }
  Aabb box;
  for (const Triangle& t : mesh) box.extend(t.bounds());
  const float step = 1.1f * box.extent().x;
  for (std::size_t copy = 0; out.size() < count; ++copy) {
    const std::size_t column = copy % 10, row = copy / 10;  // copies in rows of ten
    const Vec3 shift{step * static_cast<float>(column), step * static_cast<float>(row), 0};
    for (std::size_t i = 0; i < mesh.size() && out.size() < count; ++i)
      out.push_back({mesh[i].v0 + shift, mesh[i].v1 + shift, mesh[i].v2 + shift});
  }
  return out;
}

// Sampling and inference times over inputs of growing size (the inference must stay flat).
Json inference_scaling(const ModelInfo& sah, const ModelInfo& vvh, std::span<const Triangle> mesh,
                       const Mesh& source, bool quick) {
  const std::vector<std::size_t> sizes =
      quick ? std::vector<std::size_t>{10000, 100000}
            : std::vector<std::size_t>{10000, 30000, 100000, 300000, 1000000};
  const int reps = quick ? 5 : 21;
  Json rows = Json::array();
  for (const std::size_t n : sizes) {
    Json row{{"prims", n}};
    if (sah.model) {
      const std::vector<Triangle> tris = resized(mesh, n);
      Aabb box;
      for (const Triangle& t : tris) box.extend(t.bounds());
      std::vector<double> cdf_ms, draw_ms, infer_ms, infer_cpu;
      NeuralTop top;
      for (int r = 0; r < reps; ++r) {
        Timer t1;
        const SurfaceSampler sampler(tris);
        cdf_ms.push_back(t1.ms());
        Timer t2;
        const std::vector<Vec3> samples =
            sampler.sample(static_cast<std::size_t>(sah.model->points));
        draw_ms.push_back(t2.ms());
        NeuralTopOptions options;
        options.population = static_cast<double>(tris.size());
        top = infer_neural_top(*sah.model, samples, box, options);
        infer_ms.push_back(top.inference_ms);
        infer_cpu.push_back(top.inference_cpu_ms);
      }
      row["triangles"] = Json{{"area_prefix_sums_ms", median(cdf_ms)},
                              {"draw_ms", median(draw_ms)},
                              {"inference_ms", median(infer_ms)},
                              {"inference_cpu_ms", median(infer_cpu)},
                              {"top_depth", top.depth},
                              {"top_leaves", top.leaves()}};
    }
    if (vvh.model) {
      const std::vector<Vec3> points = sample_surface(source, n, 3, kPointStream);
      Aabb box;
      for (const Vec3& p : points) box.extend(p);
      std::vector<double> draw_ms, infer_ms, infer_cpu;
      NeuralTop top;
      PointTreeConfig config;
      config.neural.top_min = 0;  // the model's full depth at every size: the same work
      const float radius = 1e-4f * length(box.extent());
      for (int r = 0; r < reps; ++r) {
        double sampling = 0;
        top = infer_point_top(*vvh.model, points, box, config, radius, &sampling);
        draw_ms.push_back(sampling);
        infer_ms.push_back(top.inference_ms);
        infer_cpu.push_back(top.inference_cpu_ms);
      }
      row["points"] = Json{{"draw_ms", median(draw_ms)},
                           {"inference_ms", median(infer_ms)},
                           {"inference_cpu_ms", median(infer_cpu)},
                           {"top_depth", top.depth},
                           {"top_leaves", top.leaves()}};
    }
    std::string line = fmt::format("  inference at {} primitives:", n);
    for (const char* kind : {"triangles", "points"})
      if (row.contains(kind))
        line +=
            fmt::format(" {} {:.2f} ms (depth {})", kind, row[kind]["inference_ms"].get<double>(),
                        row[kind]["top_depth"].get<int>());
    fmt::print(stderr, "{}\n", line);
    rows.push_back(std::move(row));
  }
  return rows;
}

}  // namespace

void add_neural_bench_options(CLI::App& command, NeuralBenchOptions& options) {
  command
      .add_option("--runs", options.runs,
                  "Timed runs per measurement, median (default 5, --quick 1)")
      ->check(CLI::PositiveNumber);
  command.add_option("--rays", options.rays, "Rays per kind (default 262144, --quick 16384)")
      ->check(CLI::PositiveNumber);
  command
      .add_option("--points", options.points, "Surface samples for k-NN (default 1M, --quick 50k)")
      ->check(CLI::PositiveNumber);
  command.add_option("--queries", options.queries, "k-NN queries (default 200k, --quick 10k)")
      ->check(CLI::PositiveNumber);
  command.add_option("--k", options.ks, "Neighbour counts of the k-NN queries (default 1 8)")
      ->check(CLI::Range(1, 1000));
  command.add_option("--meshes", options.meshes,
                     "Meshes by name or file (default: every present mesh not used in training)");
  command.add_option("--sah-model", options.sah_model,
                     "SAH model (default: the shipped models/sah.bin)");
  command.add_option("--vvh-model", options.vvh_model,
                     "VVH model (default: the shipped models/vvh.bin)");
  command.add_option("--kd-expand", options.kd_expand,
                     "kd builder under the neural top (default sah)");
  command.add_option("--bvh-expand", options.bvh_expand,
                     "BVH builder under the neural top (default binned)");
  command.add_flag("--quick", options.quick, "Smoke test: dragon only, 1 run, few rays and points");
  command.add_option("--threads", options.threads, "Worker threads (0 = all cores)")
      ->check(CLI::NonNegativeNumber);
  command.add_option("--seed", options.seed, "Seed of rays, points and queries");
  cli::add_json_options(command, options.json, "the full report");
  command.add_option("--markdown", options.markdown_path,
                     "Write the Markdown tables to this file (default: print them)");
}

Json run_neural_bench_report(const NeuralBenchOptions& options) {
  const int runs = options.runs > 0 ? options.runs : (options.quick ? kQuickRuns : kDefaultRuns);
  const std::size_t ray_count =
      options.rays > 0 ? options.rays : (options.quick ? kQuickRays : kDefaultRays);
  const std::size_t point_count =
      options.points > 0 ? options.points : (options.quick ? kQuickPoints : kDefaultPoints);
  const std::size_t query_count =
      options.queries > 0 ? options.queries : (options.quick ? kQuickQueries : kDefaultQueries);
  const ThreadLimit limit(options.threads);
  std::vector<std::string> notes;

  Json report;
  report["benchmark"] = "neural";
  report["machine"] = machine_json(options.threads);
  const ModelInfo sah = model_info(options.sah_model, NeuralCost::sah, notes);
  const ModelInfo vvh = model_info(options.vvh_model, NeuralCost::vvh, notes);
  report["models"] = Json{{"sah", sah.json}, {"vvh", vvh.json}};
  for (const std::string& n : notes) fmt::print(stderr, "note: {}\n", n);

  // Held-out meshes: neither the training meshes nor any models/README.md names
  // in a section about training.
  std::string readme_path;
  for (const std::string& dir : model_dirs())
    if (fs::is_regular_file(fs::path(dir) / "README.md")) {
      readme_path = (fs::path(dir) / "README.md").string();
      break;
    }
  std::string training;
  if (!readme_path.empty()) {
    std::ifstream in(readme_path);
    training = training_text(std::string(std::istreambuf_iterator<char>(in), {}));
  }
  const std::string shared = shared_data_dir();
  std::vector<BenchMesh> meshes;
  Json excluded = Json::array();
  {
    std::vector<std::string> mesh_notes;
    const std::vector<BenchMesh> all = benchmark_meshes(false, mesh_notes);
    std::vector<BenchMesh> candidates =
        options.meshes.empty() ? all : select_meshes(all, options.meshes);
    if (options.quick && options.meshes.empty()) candidates = select_meshes(all, {"dragon"});
    for (const BenchMesh& m : candidates) {
      std::string why;
      if (std::find(kTrainingMeshes.begin(), kTrainingMeshes.end(), m.name) !=
          kTrainingMeshes.end())
        why = "a training mesh of the issue";
      for (const std::string& key : mesh_keys(m, shared))
        if (why.empty() && !training.empty() && training.find(key) != std::string::npos)
          why = fmt::format("named in the training section of {} ('{}')", readme_path, key);
      if (why.empty()) {
        meshes.push_back(m);
      } else {
        excluded.push_back(Json{{"name", m.name}, {"why", why}});
        fmt::print(stderr, "{}: left out, {}\n", m.name, why);
      }
    }
  }
  report["settings"] =
      Json{{"runs", runs},
           {"rays_per_kind", ray_count},
           {"kinds", {"primary", "diffuse"}},
           {"points", point_count},
           {"queries", query_count},
           {"ks", options.ks},
           {"kd_expand", options.kd_expand},
           {"bvh_expand", options.bvh_expand},
           {"point_expand", options.point_expand},
           {"seed", options.seed},
           {"quick", options.quick},
           {"models_readme", readme_path.empty() ? Json(nullptr) : Json(readme_path)},
           {"excluded_training_meshes", excluded}};

  bool identical = true;
  Json mesh_rows = Json::array();
  for (std::size_t i = 0; i < meshes.size() && (sah.model || vvh.model); ++i) {
    const BenchMesh& bm = meshes[i];
    Json mr{{"name", bm.name}, {"path", bm.path}};
    Mesh mesh;
    std::vector<Triangle> triangles;
    try {
      mesh = load_mesh(bm.path);
      triangles = mesh.triangles();
    } catch (const Error& e) {
      notes.push_back(bm.name + ": " + e.what());
      continue;
    }
    mr["triangles"] = triangles.size();
    fmt::print(stderr, "[{}/{}] {} ({} triangles)\n", i + 1, meshes.size(), bm.name,
               triangles.size());
    Json rows = Json::array();
    if (sah.model) {
      const Camera camera = bm.camera ? *bm.camera : fit_camera(triangles);
      std::vector<RaySet> sets;
      for (const RayKind kind : {RayKind::primary, RayKind::diffuse}) {
        const std::string name = kind == RayKind::primary ? "primary" : "diffuse";
        try {
          sets.push_back({name, make_rays(triangles, kind, options.seed, ray_count, camera)});
        } catch (const Error& e) {
          notes.push_back(bm.name + ": no " + name + " rays: " + e.what());
        }
      }
      for (const auto& [accel, expand] : {std::pair{std::string("kd"), options.kd_expand},
                                          std::pair{std::string("bvh"), options.bvh_expand}}) {
        try {
          Json row = compare_triangles(accel, expand, sah.path, triangles, sets, runs, identical);
          fmt::print(stderr, "  {} {}: cost ratio {:.3f}, {}\n", accel, expand,
                     row["cost_ratio"].get<double>(), ratios(row["trace"]));
          rows.push_back(std::move(row));
        } catch (const Error& e) {
          rows.push_back(Json{{"accel", accel}, {"expand", expand}, {"error", e.what()}});
          fmt::print(stderr, "  {} {} failed: {}\n", accel, expand, e.what());
        }
      }
    }
    if (vvh.model) {
      try {
        const std::vector<Vec3> points =
            sample_surface(mesh, point_count, options.seed, kPointStream);
        const std::vector<Vec3> queries =
            sample_surface(mesh, query_count, options.seed, kQueryStream);
        Json row = compare_points(options.point_expand, vvh.path, points, queries, options.ks, runs,
                                  identical);
        fmt::print(stderr, "  points {}: cost ratio {:.3f}, {}\n", options.point_expand,
                   row["cost_ratio"].get<double>(), ratios(row["knn"]));
        rows.push_back(std::move(row));
      } catch (const Error& e) {
        rows.push_back(Json{{"structure", "points"}, {"error", e.what()}});
      }
    }
    mr["results"] = rows;
    mesh_rows.push_back(std::move(mr));
  }
  report["meshes"] = mesh_rows;
  report["answers_identical"] = identical;

  if (sah.model || vvh.model) {
    fmt::print(stderr, "inference time against input size (dragon subsampled / replicated)\n");
    const Mesh dragon = load_mesh(find_data_file("dragon_100k/dragon.obj.gz"));
    const std::vector<Triangle> tris = dragon.triangles();
    report["inference"] = inference_scaling(sah, vvh, tris, dragon, options.quick);
  }
  report["machine"]["load_average_end"] = load_average();
  report["notes"] = notes;
  return report;
}

namespace {

std::string num(const Json& v, int decimals) {
  if (!v.is_number()) return "–";
  return fmt::format("{:.{}f}", v.get<double>(), decimals);
}

double geomean(const std::vector<double>& v) {
  if (v.empty()) return 0;
  double s = 0;
  for (const double x : v) s += std::log(x);
  return std::exp(s / static_cast<double>(v.size()));
}

}  // namespace

std::string neural_markdown_report(const Json& report) {
  std::string md = "### Neural top + expansion against the expansion builder alone (paper 003)\n\n";
  const Json& models = report["models"];
  for (const char* cost : {"sah", "vvh"}) {
    const Json& m = models[cost];
    if (m.value("absent", false))
      md += fmt::format(
          "- **{} model: absent** — models/{}.bin was not found, its part is missing.\n", cost,
          cost);
    else if (m.contains("error"))
      md += fmt::format("- **{} model unusable**: {}\n", cost, m["error"].get<std::string>());
    else
      md += fmt::format("- {} model: `{}`, depth {}, M = {}, {} parameters\n", cost,
                        m["path"].get<std::string>(), m["depth"].get<int>(), m["points"].get<int>(),
                        m["parameters"].get<std::size_t>());
  }
  const Json& settings = report["settings"];
  std::string left_out;
  for (const Json& e : settings["excluded_training_meshes"])
    left_out += (left_out.empty() ? "" : ", ") + e["name"].get<std::string>();
  md += fmt::format(
      "- held-out meshes only (left out as training meshes: {}); {} runs (median, "
      "alternating the two trees), {} rays per kind, {} points and {} queries (k = {}) "
      "per mesh; inferred-top cells of fewer than {} primitives are left to B (`--top-min`, "
      "the default), so a small mesh gets no top and B's own tree\n\n",
      left_out.empty() ? "none" : left_out, settings["runs"].get<int>(),
      settings["rays_per_kind"].get<std::size_t>(), settings["points"].get<std::size_t>(),
      settings["queries"].get<std::size_t>(), settings["ks"].dump(), kNeuralTopMinPrims);

  std::vector<double> cost_kd, cost_bvh, cost_pts, trace_kd, trace_bvh, knn;
  std::vector<double> greedy_kd, greedy_bvh, greedy_pts;  // the samples' greedy top + B / B
  std::string rt =
      "| mesh | tris | structure | SAH cost B | neural+B | ratio | greedy top+B | build ms B | "
      "neural+B | inference ms | primary Mrays/s B | neural+B | ratio | diffuse Mrays/s B | "
      "neural+B | ratio | same hits |\n"
      "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
  std::string nn =
      "| mesh | points | k | VVH cost B | neural+B | ratio | greedy top+B | build ms B | "
      "neural+B | inference ms | k-NN queries/s B | neural+B | ratio | same neighbours |\n"
      "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n";
  bool any_rt = false, any_nn = false;
  for (const Json& mesh : report["meshes"]) {
    for (const Json& row : mesh["results"]) {
      if (row.contains("error")) {
        md +=
            fmt::format("- {} {}: failed: {}\n", mesh["name"].get<std::string>(),
                        row.value("accel", std::string("points")), row["error"].get<std::string>());
        continue;
      }
      if (row.contains("accel")) {
        any_rt = true;
        const std::string accel = row["accel"].get<std::string>();
        const Json& tr = row["trace"];
        const Json none = Json::object();
        const Json& p = tr.contains("primary") ? tr["primary"] : none;
        const Json& d = tr.contains("diffuse") ? tr["diffuse"] : none;
        const bool same = p.value("hits_identical", true) && d.value("hits_identical", true);
        rt += fmt::format(
            "| {} | {} | {} {} | {} | {} | **{}** | {} | {} | {} | {} | {} | {} | **{}** | {} | "
            "{} | **{}** | {} |\n",
            mesh["name"].get<std::string>(), mesh["triangles"].get<std::size_t>(), accel,
            row["expand"].get<std::string>(), num(row["base"]["sah_cost"], 1),
            num(row["neural"]["sah_cost"], 1), num(row["cost_ratio"], 3),
            num(row.value("greedy_top_cost_ratio", Json()), 3), num(row["base"]["build_ms"], 1),
            num(row["neural"]["build_ms"], 1), num(row["neural"]["inference_ms"], 2),
            num(p["base_mrays_per_s"], 2), num(p["neural_mrays_per_s"], 2), num(p["ratio"], 3),
            num(d["base_mrays_per_s"], 2), num(d["neural_mrays_per_s"], 2), num(d["ratio"], 3),
            same ? "yes" : "**NO**");
        (accel == "kd" ? cost_kd : cost_bvh).push_back(row["cost_ratio"].get<double>());
        if (row.contains("greedy_top_cost_ratio"))
          (accel == "kd" ? greedy_kd : greedy_bvh)
              .push_back(row["greedy_top_cost_ratio"].get<double>());
        for (const Json* t : {&p, &d})
          if (t->contains("ratio"))
            (accel == "kd" ? trace_kd : trace_bvh).push_back((*t)["ratio"].get<double>());
      } else {
        any_nn = true;
        for (const Json& q : row["knn"]) {
          nn += fmt::format(
              "| {} | {} | {} | {} | {} | **{}** | {} | {} | {} | {} | {} | {} | **{}** | {} |\n",
              mesh["name"].get<std::string>(), settings["points"].get<std::size_t>(),
              q["k"].get<int>(), num(row["base"]["vvh_cost"], 3), num(row["neural"]["vvh_cost"], 3),
              num(row["cost_ratio"], 3), num(row.value("greedy_top_cost_ratio", Json()), 3),
              num(row["base"]["build_ms"], 1), num(row["neural"]["build_ms"], 1),
              num(row["neural"]["inference_ms"], 2), num(q["base_queries_per_s"], 0),
              num(q["neural_queries_per_s"], 0), num(q["ratio"], 3),
              q["neighbors_identical"].get<bool>() ? "yes" : "**NO**");
          knn.push_back(q["ratio"].get<double>());
        }
        cost_pts.push_back(row["cost_ratio"].get<double>());
        if (row.contains("greedy_top_cost_ratio"))
          greedy_pts.push_back(row["greedy_top_cost_ratio"].get<double>());
      }
    }
  }
  if (any_rt)
    md +=
        "Ray tracing (B = the expansion builder; ratios are neural+B / B; *greedy top+B*: the "
        "cost ratio of a top built by an exact greedy sweep over the same samples instead of "
        "the network, expanded alike, paper 003 Fig. 3's baseline):\n\n" +
        rt + "\n";
  if (any_nn) md += "Nearest neighbours:\n\n" + nn + "\n";

  if (report.contains("inference")) {
    md +=
        "Inference time against input size (dragon subsampled or replicated; medians). The "
        "network's greedy inference works on the M samples only; drawing area-weighted samples "
        "needs the triangles' area prefix sums, one O(N) pass, timed apart:\n\n"
        "| primitives | triangles: area prefix sums ms | draw M ms | inference ms (CPU ms) | "
        "points: draw M ms | inference ms (CPU ms) |\n"
        "|---:|---:|---:|---:|---:|---:|\n";
    std::vector<double> inf_t, inf_p;
    for (const Json& row : report["inference"]) {
      const Json none = Json::object();
      const Json& t = row.contains("triangles") ? row["triangles"] : none;
      const Json& p = row.contains("points") ? row["points"] : none;
      md += fmt::format(
          "| {} | {} | {} | {} ({}) | {} | {} ({}) |\n", row["prims"].get<std::size_t>(),
          num(t.value("area_prefix_sums_ms", Json()), 2), num(t.value("draw_ms", Json()), 3),
          num(t.value("inference_ms", Json()), 3), num(t.value("inference_cpu_ms", Json()), 3),
          num(p.value("draw_ms", Json()), 3), num(p.value("inference_ms", Json()), 3),
          num(p.value("inference_cpu_ms", Json()), 3));
      if (t.contains("inference_cpu_ms")) inf_t.push_back(t["inference_cpu_ms"].get<double>());
      if (p.contains("inference_cpu_ms")) inf_p.push_back(p["inference_cpu_ms"].get<double>());
    }
    md += "\n";
    const auto spread = [](const std::vector<double>& v) {
      return v.empty()
                 ? 0.0
                 : *std::max_element(v.begin(), v.end()) / *std::min_element(v.begin(), v.end());
    };
    if (!inf_t.empty())
      md += fmt::format(
          "- SAH model inference: at most {:.3f} CPU ms (target ≤ 3 ms for M = 2048, depth 6), "
          "largest / smallest over the sizes {:.2f}×\n",
          *std::max_element(inf_t.begin(), inf_t.end()), spread(inf_t));
    if (!inf_p.empty())
      md +=
          fmt::format("- VVH model inference: at most {:.3f} CPU ms, largest / smallest {:.2f}×\n",
                      *std::max_element(inf_p.begin(), inf_p.end()), spread(inf_p));
  }
  // Worst: the largest cost ratio, the smallest throughput ratio.
  const auto line = [&](const char* what, const std::vector<double>& v, bool cost) {
    if (v.empty()) return;
    const double worst =
        cost ? *std::max_element(v.begin(), v.end()) : *std::min_element(v.begin(), v.end());
    md += fmt::format("- {}: geometric mean {:.3f}, worst {:.3f} (target {})\n", what, geomean(v),
                      worst, cost ? "≤ 1.00" : "≥ 1.00");
  };
  line("kd SAH cost ratio", cost_kd, true);
  line("BVH SAH cost ratio", cost_bvh, true);
  line("point-tree VVH cost ratio", cost_pts, true);
  const auto baseline = [&](const char* what, const std::vector<double>& v,
                            const std::vector<double>& neural) {
    if (v.empty()) return;
    std::size_t better = 0, equal = 0;
    for (std::size_t i = 0; i < v.size() && i < neural.size(); ++i) {
      if (neural[i] < v[i])
        ++better;
      else if (neural[i] == v[i])
        ++equal;
    }
    md += fmt::format(
        "- {} with the samples' greedy top instead of the network: geometric mean {:.3f}, "
        "worst {:.3f}; the network's top is cheaper on {}, the same on {} (no top), dearer on "
        "{} of {}\n",
        what, geomean(v), *std::max_element(v.begin(), v.end()), better, equal,
        v.size() - better - equal, v.size());
  };
  baseline("kd SAH cost ratio", greedy_kd, cost_kd);
  baseline("BVH SAH cost ratio", greedy_bvh, cost_bvh);
  baseline("point-tree VVH cost ratio", greedy_pts, cost_pts);
  line("kd trace throughput ratio", trace_kd, false);
  line("BVH trace throughput ratio", trace_bvh, false);
  line("k-NN throughput ratio", knn, false);
  if (!report["answers_identical"].get<bool>())
    md += "- **Some neural trees answered differently from their expansion builder's trees.**\n";
  for (const Json& n : report["notes"]) md += "- note: " + n.get<std::string>() + "\n";
  return md;
}

int run_neural_bench(const NeuralBenchOptions& options) {
  check_output_folders({options.json.file, options.markdown_path});
  const Json report = run_neural_bench_report(options);
  emit_report(options.json, options.markdown_path, report, neural_markdown_report(report));
  return report["answers_identical"].get<bool>() ? 0 : 1;
}

}  // namespace splitray::bench

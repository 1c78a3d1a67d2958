// splitray trace MESH --accel A --rays N --kind K --seed S: casts a reproducible ray set
// (make_rays: it depends on the mesh, kind, seed, camera and N, never on the structure) and
// prints checksums that two correct structures agree on exactly, and the tracing speed.
#include <fmt/core.h>

#include <algorithm>
#include <cstdint>
#include <memory>
#include <optional>

#include "commands.hpp"
#include "file_options.hpp"
#include "json_output.hpp"
#include "options.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/memory_budget.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/io/npy.hpp"
#include "splitray/render/ray_sets.hpp"

namespace splitray::app {

namespace {

struct TraceCommand {
  std::string mesh;
  AccelOptions accel;
  std::size_t rays = 100000;
  std::string kind = "primary";
  std::uint64_t seed = 1;
  std::string camera;
  bool any = false;
  bool single = false;  // time the single-ray calls (Embree: rtcIntersect1) instead of batched
  int repeat = 1;
  std::string rays_in, hits_out;  // the user's rays (.npy), the hits written back (.npz)
  cli::JsonOutput json;
};

// --rays-in: an N x 6 array of origins and directions (float32 or float64; directions need
// not be unit length, t is measured in their units, as Open3D's RaycastingScene does).
std::vector<Ray> read_rays(const std::string& path) {
  const FloatArray a = read_npy_rows(path, 6, "rays (ox, oy, oz, dx, dy, dz)");
  std::vector<Ray> rays(a.shape[0]);
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const float* r = &a.values[i * 6];
    rays[i] = Ray{{r[0], r[1], r[2]}, {r[3], r[4], r[5]}};
    if (rays[i].dir == Vec3{0})
      throw Error(path, "rays: row " + std::to_string(i) + " has a zero direction");
  }
  return rays;
}

// --hits-out: the hits under Open3D RaycastingScene.cast_rays' names and conventions.
void write_hits(const std::string& path, const std::vector<Triangle>& triangles,
                const std::vector<Hit>& hits) {
  const std::size_t n = hits.size();
  std::vector<float> t(n), uvs(2 * n, 0.0f), normals(3 * n, 0.0f);
  std::vector<std::uint32_t> ids(n, kInvalidId), geometry(n, kInvalidId);
  for (std::size_t i = 0; i < n; ++i) {
    const Hit& h = hits[i];
    t[i] = h.found() ? h.t : kInfinity;
    if (!h.found()) continue;
    ids[i] = h.prim;
    geometry[i] = 0;
    uvs[2 * i] = h.u;
    uvs[2 * i + 1] = h.v;
    const Vec3 normal = normalize(triangles[h.prim].geometric_normal());
    for (int c = 0; c < 3; ++c) normals[3 * i + c] = normal[c];
  }
  write_npz(path, {{"t_hit", npy_array({n}, t)},
                   {"geometry_ids", npy_array({n}, geometry)},
                   {"primitive_ids", npy_array({n}, ids)},
                   {"primitive_uvs", npy_array({n, 2}, uvs)},
                   {"primitive_normals", npy_array({n, 3}, normals)}});
}

struct Totals {
  std::uint64_t hits = 0;
  double sum_t = 0;               // closest hits only, summed in ray order
  std::uint64_t id_checksum = 0;  // sum of (prim + 1), 0 for a miss
};

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

void run(const TraceCommand& command) {
  if (!command.hits_out.empty()) {
    if (command.any)
      throw Error("--hits-out", "writes closest hits: it cannot be combined with --any");
    check_output_path(command.hits_out, ".npz");
  }
  const Geometry geometry = load_geometry(command.mesh);
  const ThreadLimit limit(command.accel.build.threads);
  const auto accel = make_accel(command.accel.accel, geometry.triangles, command.accel.build);
  const AccelStats& stats = accel->stats();

  std::optional<Camera> camera;
  if (!command.camera.empty())
    camera = to_camera(parse_camera(command.camera), Camera{}.vfov_degrees);
  const RayKind kind = parse_ray_kind(command.kind);
  if (command.rays_in.empty())
    check_memory(command.rays, sizeof(Ray) + sizeof(Hit), std::to_string(command.rays) + " rays",
                 "--rays");
  const Timer ray_timer;
  const std::vector<Ray> rays =
      !command.rays_in.empty()
          ? read_rays(command.rays_in)
          : make_rays(geometry.triangles, kind, command.seed, command.rays, camera);
  const double rays_ms = ray_timer.ms();

  // Only the tracing is timed (batched, or one single-ray call per ray with --single); the
  // median of --repeat runs is reported.
  std::vector<double> times, cpu_times;
  Totals totals;
  if (command.any) {
    std::vector<std::uint8_t> occluded(rays.size());
    for (int r = 0; r < command.repeat; ++r) {
      const Timer timer;
      const CpuTimer cpu;
      if (command.single)
        accel->occluded_each(rays, occluded);
      else
        accel->occluded(rays, occluded);
      times.push_back(timer.ms());
      cpu_times.push_back(cpu.ms());
    }
    for (const std::uint8_t o : occluded) totals.hits += o ? 1 : 0;
  } else {
    std::vector<Hit> hits(rays.size());
    for (int r = 0; r < command.repeat; ++r) {
      const Timer timer;
      const CpuTimer cpu;
      if (command.single)
        accel->intersect_each(rays, hits);
      else
        accel->intersect(rays, hits);
      times.push_back(timer.ms());
      cpu_times.push_back(cpu.ms());
    }
    if (!command.hits_out.empty()) write_hits(command.hits_out, geometry.triangles, hits);
    for (const Hit& hit : hits) {
      if (!hit.found()) continue;
      ++totals.hits;
      totals.sum_t += hit.t;
      totals.id_checksum += static_cast<std::uint64_t>(hit.prim) + 1;
    }
  }
  const double ms = median(times);
  const double mrays_per_s = ms > 0 ? rays.size() / (ms * 1e3) : 0.0;
  const double cpu_ms = median(cpu_times);
  const double mrays_per_cpu_s = cpu_ms > 0 ? rays.size() / (cpu_ms * 1e3) : 0.0;
  const int threads = effective_threads(command.accel.build.threads);

  if (command.json.wanted()) {
    using Json = nlohmann::ordered_json;
    const Json sum_t = command.any ? Json(nullptr) : Json(totals.sum_t);
    const Json id_checksum = command.any ? Json(nullptr) : Json(totals.id_checksum);
    Json object = {
        {"rays", rays.size()},
        {"hits", totals.hits},
        {"sum_t", sum_t},
        {"id_checksum", id_checksum},
        {"ms", ms},
        {"mrays_per_s", mrays_per_s},
        {"cpu_ms", cpu_ms},
        {"mrays_per_cpu_s", mrays_per_cpu_s},
        {"build_ms", stats.build_ms},
        {"accel", stats.accel},
        {"builder", stats.builder},
        {"prims", stats.prims},
        {"kind", command.kind},
        {"seed", command.seed},
        {"any", command.any},
        {"single", command.single},
        {"repeat", command.repeat},
        {"threads", threads},
        {"mesh", command.mesh},
        {"load_ms", geometry.load_ms},
        {"rays_ms", rays_ms},
    };
    if (camera) object["camera"] = command.camera;
    if (!command.rays_in.empty()) object["rays_in"] = command.rays_in;
    if (!command.hits_out.empty()) object["hits_out"] = command.hits_out;
    if (stats.inference_ms) object["inference_ms"] = *stats.inference_ms;  // --builder neural
    if (stats.top_depth) object["top_depth"] = *stats.top_depth;
    cli::emit_json(command.json, object);
    if (command.json.print) return;
  }
  fmt::print("splitray trace: {} on {}, {} {} rays (seed {}){}\n", structure_name(stats),
             command.mesh, rays.size(), command.kind, command.seed, command.any ? ", any hit" : "");
  const std::string not_any = "n/a (--any)";
  print_table({
      {"rays", std::to_string(rays.size())},
      {"hits", std::to_string(totals.hits)},
      {"sum_t", command.any ? not_any : fmt::format("{}", totals.sum_t)},
      {"id_checksum", command.any ? not_any : std::to_string(totals.id_checksum)},
      {"ms", fmt::format("{:.2f}", ms)},
      {"mrays_per_s", fmt::format("{:.3f}", mrays_per_s)},
      {"mrays_per_cpu_s", fmt::format("{:.3f}", mrays_per_cpu_s)},
      {"build_ms", fmt::format("{:.2f}", stats.build_ms)},
      {"prims", std::to_string(stats.prims)},
      {"threads", std::to_string(threads)},
  });
}

}  // namespace

void add_trace_command(CLI::App& app) {
  auto command = std::make_shared<TraceCommand>();
  CLI::App* sub = app.add_subcommand(
      "trace", "Cast a reproducible ray set through a structure and print hit checksums and speed");
  sub->add_option("MESH", command->mesh,
                  "Mesh file (any format of render; also *.gz) or JSON scene")
      ->required();
  add_accel_options(*sub, command->accel);
  CLI::Option* count =
      sub->add_option("-n,--rays", command->rays, "Number of rays")->check(CLI::Range(1, 1 << 30));
  CLI::Option* kind_option =
      sub->add_option(
             "-k,--kind", command->kind,
             "primary: through the pixels of --camera (default: a camera framed on the mesh "
             "from outside); random: uniform origins in the bounding box, uniform directions; "
             "diffuse: from the primary hits, cosine-distributed about the normal")
          ->check(CLI::IsMember({"primary", "random", "diffuse"}));
  CLI::Option* seed = sub->add_option("-s,--seed", command->seed, "Seed of the ray set");
  CLI::Option* camera = add_camera_option(*sub, command->camera);
  sub->add_option("--rays-in", command->rays_in,
                  "Trace your own rays instead: a NumPy .npy file of N x 6 floats (origin, "
                  "direction; float32 or float64), t in units of the direction, as Open3D's "
                  "RaycastingScene")
      ->excludes(count)
      ->excludes(kind_option)
      ->excludes(seed)
      ->excludes(camera);
  sub->add_option("--hits-out", command->hits_out,
                  "Write every ray's closest hit to this .npz with Open3D RaycastingScene's "
                  "names: t_hit (float32, inf on a miss), geometry_ids and primitive_ids "
                  "(uint32, 4294967295 on a miss), primitive_uvs (N x 2 barycentrics of vertices "
                  "1 and 2), primitive_normals (N x 3 unit geometric normals; 0 on a miss)");
  sub->add_flag("--any", command->any,
                "Any-hit (occlusion) queries instead of closest hits; sum_t and id_checksum are "
                "then n/a (null)");
  sub->add_flag("--single", command->single,
                "Time the structure's single-ray call on every ray (Embree: rtcIntersect1 / "
                "rtcOccluded1) instead of its batched call (Embree: 8-ray packets)");
  sub->add_option("-r,--repeat", command->repeat,
                  "Trace the rays this many times and report the median time")
      ->check(CLI::Range(1, 1000));
  cli::add_json_options(
      *sub, command->json,
      "rays, hits, sum_t, id_checksum, ms, mrays_per_s, cpu_ms, "
      "mrays_per_cpu_s, build_ms, "
      "accel, builder, prims, kind, seed, any, single, repeat, threads, mesh, load_ms, rays_ms");
  cli::input_files(sub->get_option("MESH"));
  cli::input_files(sub->get_option("--rays-in"));
  cli::output_file(sub->get_option("--hits-out"));
  sub->callback([command] { run(*command); });
}

}  // namespace splitray::app

// splitray render [SCENE] -o FILE.png|.exr|.pfm: Whitted ray tracing (or the hybrid renderer)
// of a mesh, a JSON or BART scene or the built-in default scene, with progress on stderr and a
// summary at the end.
#include <fmt/core.h>

#include <cstring>
#include <filesystem>
#include <memory>
#include <optional>

#include "commands.hpp"
#include "dist_render.hpp"
#include "file_options.hpp"
#include "json_output.hpp"
#include "options.hpp"
#include "progress.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/dist/world.hpp"
#include "splitray/io/load_scene.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/render/default_scene.hpp"
#include "splitray/render/whitted.hpp"
#if SPLITRAY_HAS_RENDER_GL
#include "splitray/render_gl/hybrid.hpp"
#endif

namespace splitray::app {

namespace {

struct RenderCommand {
  std::string scene;  // empty = built-in default scene
  std::string output = "splitray.png";
  std::string camera;
  int width = 800;
  int height = 600;
  int max_depth = 5;
  std::string mode = "whitted";  // or "hybrid" (GPU + CPU, paper 002)
  AccelOptions accel;
  bool exr_float = false;
  std::string crop;    // X0,X1,Y0,Y1 fractions (pbrt's --cropwindow); empty = the whole image
  int tile_size = 64;  // under mpirun: the tiles rank 0 hands out
  cli::JsonOutput json;
};

// --crop X0,X1,Y0,Y1 as pixels of the width x height image.
std::optional<PixelRect> parse_crop(const std::string& text, int width, int height) {
  if (text.empty()) return std::nullopt;
  double f[4];
  char tail = 0;
  if (std::sscanf(text.c_str(), "%lf,%lf,%lf,%lf%c", &f[0], &f[1], &f[2], &f[3], &tail) != 4)
    throw Error("--crop " + text, "expected four fractions X0,X1,Y0,Y1 (e.g. 0,0.5,0,1)");
  return crop_pixels(f[0], f[1], f[2], f[3], width, height, "--crop " + text);
}

// --mode hybrid: the five-pass GPU + CPU renderer in a headless OpenGL context; its ray count
// is the CPU's rays only. Builds without render_gl and machines without OpenGL 4.5 get an Error.
RenderResult render_mode(const RenderCommand& command, const Scene& scene, const Camera& camera,
                         const RenderOptions& options) {
  if (command.mode != "hybrid") return render_whitted(scene, camera, options);
#if SPLITRAY_HAS_RENDER_GL
  RenderResult result = render_hybrid(scene, camera, HybridOptions::from(options));
  if (options.crop) result.image = crop_image(result.image, *options.crop);
  return result;
#else
  (void)scene;
  (void)camera;
  throw Error("--mode hybrid", "this splitray was built without OpenGL (SPLITRAY_WITH_GL=OFF)");
#endif
}

void run(const RenderCommand& command) {
  check_image_path(command.output);  // before any work: a bad name fails at once
  const std::optional<PixelRect> crop = parse_crop(command.crop, command.width, command.height);
  const dist::World& world = dist::world();
  const bool lead = world.rank == 0;  // under mpirun only rank 0 reports and writes
  cli::ProgressBar bar(lead ? "render" : "");
  const auto status = [&](const std::string& text) {
    if (lead) bar.status(text);
  };
  status(command.scene.empty() ? "generating the default scene ..."
                               : "loading " + command.scene + " ...");
  const Timer load_timer;
  Scene scene;
  dist::all_or_none(
      [&] { scene = command.scene.empty() ? default_scene() : load_scene(command.scene); });
  const double load_ms = load_timer.ms();
  if (lead)
    for (const std::string& warning : scene.warnings) cli::warn(warning);

  const float default_vfov = scene.camera ? scene.camera->vfov_degrees : Camera{}.vfov_degrees;
  const Camera camera = !command.camera.empty()
                            ? to_camera(parse_camera(command.camera), default_vfov)
                            : (scene.camera ? *scene.camera : Camera::frame(scene.bounds()));

  RenderOptions options;
  options.width = command.width;
  options.height = command.height;
  options.max_depth = command.max_depth;
  options.accel = command.accel.accel;
  options.build = command.accel.build;
  options.crop = crop;
  status(fmt::format("building {} on the scene ...", command.accel.accel));
  options.progress = [&bar](double fraction) { bar.update(fraction); };
  std::optional<DistRender> distributed;
  if (world.distributed())
    distributed = render_distributed(scene, camera, options, command.tile_size, command.mode);
  if (!lead) return;
  const RenderResult result =
      distributed ? std::move(distributed->result) : render_mode(command, scene, camera, options);
  bar.status("writing " + command.output);
  write_image(command.output, result.image, {.exr_float = command.exr_float});
  bar.finish();
  const std::string warning = coverage_warning(result.coverage, result.lights.size());
  if (!warning.empty()) cli::warn(warning);

  const AccelStats& stats = result.accel_stats;
  // Hybrid: the CPU's rays over the CPU pass's time (the GPU traces no rays).
  const bool hybrid = command.mode == "hybrid";
  const double ray_ms = hybrid ? result.cpu_ms : result.render_ms;
  const double mrays_per_s = ray_ms > 0 ? result.rays / (ray_ms * 1e3) : 0.0;
  const int threads = effective_threads(command.accel.build.threads);
  const std::string scene_name = command.scene.empty() ? "default" : command.scene;
  if (command.json.wanted()) {
    nlohmann::ordered_json object = {
        {"scene", scene_name},
        {"output", command.output},
        {"width", command.width},
        {"height", command.height},
        {"max_depth", command.max_depth},
        {"mode", command.mode},
        {"threads", threads},
        {"triangles", stats.prims},
        {"accel", stats.accel},
        {"builder", stats.builder},
        {"load_ms", load_ms},
        {"build_ms", stats.build_ms},
        {"render_ms", result.render_ms},
        {"rays", result.rays},
        {"mrays_per_s", mrays_per_s},
        {"lights", result.lights.size()},
        {"lights_fitted", scene.lights_fit_view},
        {"lit_share", result.coverage.probes > 0
                          ? static_cast<double>(result.coverage.lit) / result.coverage.probes
                          : 0.0},
        {"accel_stats", stats_json(stats)}};
    object["crop"] = crop ? nlohmann::ordered_json{{"x0", crop->x0},
                                                   {"x1", crop->x1},
                                                   {"y0", crop->y0},
                                                   {"y1", crop->y1}}
                          : nlohmann::ordered_json();
    object["ranks"] = world.size;
    if (distributed) {
      object["tiles"] = distributed->tiles;
      nlohmann::ordered_json ranks = nlohmann::ordered_json::array();
      for (const dist::RankStats& r : distributed->ranks)
        ranks.push_back({{"rank", r.rank},
                         {"tiles", r.units},
                         {"compute_ms", r.compute_ms},
                         {"comm_ms", r.comm_ms},
                         {"assembly_ms", r.collect_ms},
                         {"idle_ms", r.idle_ms}});
      object["rank_stats"] = ranks;
    }
    if (hybrid) {
      object["gl_renderer"] = result.gl_renderer;
      object["cpu_ms"] = result.cpu_ms;
    }
    cli::emit_json(command.json, object);
    if (command.json.print) return;
  }
  fmt::print("splitray render: wrote {} ({} x {})\n", command.output, result.image.width,
             result.image.height);
  std::vector<std::pair<std::string, std::string>> rows = {
      {"scene", command.scene.empty() ? "built-in default scene" : command.scene},
      {"triangles", std::to_string(stats.prims)},
      {"structure",
       fmt::format("{}, {:.2f} MiB", structure_name(stats), stats.bytes / (1024.0 * 1024.0))},
      {"load", fmt::format("{:.1f} ms", load_ms)},
      {"build", fmt::format("{:.1f} ms", stats.build_ms)},
      {"render", fmt::format("{:.1f} ms ({}), {} threads, max depth {}", result.render_ms,
                             command.mode, threads, command.max_depth)},
      {"rays", hybrid ? fmt::format("{} on the CPU in {:.1f} ms ({:.2f} Mrays/s)", result.rays,
                                    result.cpu_ms, mrays_per_s)
                      : fmt::format("{} ({:.2f} Mrays/s)", result.rays, mrays_per_s)},
      {"lights",
       fmt::format("{}{}", result.lights.size(),
                   scene.lights_fit_view ? " (fitted to the view: the scene has none)" : "")},
  };
  if (hybrid) rows.emplace_back("OpenGL", result.gl_renderer);
  if (crop)
    rows.emplace_back(
        "crop", fmt::format("pixels {}..{} x {}..{} of {} x {}", crop->x0, crop->x1 - 1, crop->y0,
                            crop->y1 - 1, command.width, command.height));
  if (distributed)
    rows.emplace_back("ranks",
                      command.mode == "hybrid"
                          ? fmt::format("{} (mpirun), {} bands of {} rows", world.size,
                                        distributed->tiles, command.tile_size)
                          : fmt::format("{} (mpirun), {} tiles of {} x {}", world.size,
                                        distributed->tiles, command.tile_size, command.tile_size));
  print_table(rows);
}

}  // namespace

void add_render_command(CLI::App& app) {
  auto command = std::make_shared<RenderCommand>();
  CLI::App* sub = app.add_subcommand(
      "render",
      "Render a mesh, a JSON or BART scene or the built-in default scene to PNG, EXR or PFM");
  sub->add_option("SCENE", command->scene,
                  "Mesh file (OBJ, PLY, STL, OFF, glTF/GLB, COLLADA, MD2, ...; also *.gz; with its "
                  "materials and textures), JSON scene file or BART scene (*.aff); without it the "
                  "built-in default scene");
  sub->add_option("-o,--output", command->output,
                  "Image to write (atomically), format by extension: .png (8-bit sRGB), .exr "
                  "(OpenEXR, linear half; --exr-float: float), .pfm (linear float)");
  sub->add_flag("--exr-float", command->exr_float,
                "Write .exr with 32-bit float channels (default: half)");
  sub->add_option("-W,--width", command->width, "Image width in pixels")
      ->check(CLI::Range(1, 16384));
  sub->add_option("-H,--height", command->height, "Image height in pixels")
      ->check(CLI::Range(1, 16384));
  add_camera_option(*sub, command->camera)
      ->description(
          "Camera eye EX,EY,EZ, target TX,TY,TZ and optional vertical FOV in degrees (up is +y); "
          "default: the scene's camera, or one framed on the scene");
  sub->add_option("-d,--max-depth", command->max_depth, "Reflection and refraction bounces")
      ->check(CLI::Range(0, 64));
  sub->add_option("--mode", command->mode,
                  "whitted: CPU ray tracing; hybrid: primary rays and shadow maps on the GPU "
                  "(OpenGL 4.5, headless), reflections and shadow boundaries on the CPU")
      ->check(CLI::IsMember({"whitted", "hybrid"}));
  sub->add_option("--crop", command->crop,
                  "Render only the window X0,X1,Y0,Y1 (fractions of the width and height, as "
                  "pbrt's --cropwindow: pixels ceil(W*X0)..ceil(W*X1)-1); the image has the "
                  "window's size and its pixels are the full image's");
  sub->add_option(
         "--tile-size", command->tile_size,
         "Under mpirun: the square tiles (pixels) rank 0 hands out to the ranks (--mode hybrid: "
         "bands of this many rows, each one GPU frame whose CPU pass traces the band)")
      ->check(CLI::Range(1, 16384));
  add_accel_options(*sub, command->accel);
  cli::add_json_options(*sub, command->json, "the keys of the README's render table");
  cli::input_files(sub->get_option("SCENE"));
  cli::output_file(sub->get_option("--output"));
  sub->callback([command] { run(*command); });
}

}  // namespace splitray::app

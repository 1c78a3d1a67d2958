// splitray render [SCENE] -o FILE.png|.exr|.pfm: Whitted ray tracing (or the hybrid renderer)
// of a mesh, a JSON or BART scene or the built-in default scene, with progress on stderr and a
// summary at the end.
#include <fmt/core.h>

#include <filesystem>
#include <memory>

#include "commands.hpp"
#include "json_output.hpp"
#include "options.hpp"
#include "progress.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/timer.hpp"
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
  cli::JsonOutput json;
};

// --mode hybrid: the five-pass GPU + CPU renderer in a headless OpenGL context; its ray count
// is the CPU's rays only. Builds without render_gl and machines without OpenGL 4.5 get an Error.
RenderResult render_mode(const RenderCommand& command, const Scene& scene, const Camera& camera,
                         const RenderOptions& options) {
  if (command.mode != "hybrid") return render_whitted(scene, camera, options);
#if SPLITRAY_HAS_RENDER_GL
  HybridOptions hybrid;
  hybrid.width = options.width;
  hybrid.height = options.height;
  hybrid.max_depth = options.max_depth;
  hybrid.accel = options.accel;
  hybrid.build = options.build;
  return render_hybrid(scene, camera, hybrid);
#else
  (void)scene;
  (void)camera;
  throw Error("--mode hybrid", "this splitray was built without OpenGL (SPLITRAY_WITH_GL=OFF)");
#endif
}

void run(const RenderCommand& command) {
  check_image_path(command.output);  // before any work: a bad name fails at once
  cli::ProgressBar bar("render");
  bar.status(command.scene.empty() ? "generating the default scene ..." : "loading " + command.scene + " ...");
  const Timer load_timer;
  const Scene scene = command.scene.empty() ? default_scene() : load_scene(command.scene);
  const double load_ms = load_timer.ms();
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
  bar.status(fmt::format("building {} on the scene ...", command.accel.accel));
  options.progress = [&bar](double fraction) { bar.update(fraction); };
  const RenderResult result = render_mode(command, scene, camera, options);
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
    nlohmann::ordered_json object = {{"scene", scene_name},
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
                                                       ? static_cast<double>(result.coverage.lit) /
                                                             result.coverage.probes
                                                       : 0.0},
                                     {"accel_stats", stats_json(stats)}};
    if (hybrid) {
      object["gl_renderer"] = result.gl_renderer;
      object["cpu_ms"] = result.cpu_ms;
    }
    cli::emit_json(command.json, object);
    if (command.json.print) return;
  }
  fmt::print("splitray render: wrote {} ({} x {})\n", command.output, command.width, command.height);
  std::vector<std::pair<std::string, std::string>> rows = {
      {"scene", command.scene.empty() ? "built-in default scene" : command.scene},
      {"triangles", std::to_string(stats.prims)},
      {"structure", fmt::format("{}, {:.2f} MiB", structure_name(stats),
                                stats.bytes / (1024.0 * 1024.0))},
      {"load", fmt::format("{:.1f} ms", load_ms)},
      {"build", fmt::format("{:.1f} ms", stats.build_ms)},
      {"render", fmt::format("{:.1f} ms ({}), {} threads, max depth {}", result.render_ms,
                             command.mode, threads, command.max_depth)},
      {"rays", hybrid ? fmt::format("{} on the CPU in {:.1f} ms ({:.2f} Mrays/s)", result.rays,
                                    result.cpu_ms, mrays_per_s)
                      : fmt::format("{} ({:.2f} Mrays/s)", result.rays, mrays_per_s)},
      {"lights", fmt::format("{}{}", result.lights.size(),
                             scene.lights_fit_view ? " (fitted to the view: the scene has none)"
                                                   : "")},
  };
  if (hybrid) rows.emplace_back("OpenGL", result.gl_renderer);
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
  sub->add_flag("--exr-float", command->exr_float, "Write .exr with 32-bit float channels (default: half)");
  sub->add_option("-W,--width", command->width, "Image width in pixels")->check(CLI::Range(1, 16384));
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
  add_accel_options(*sub, command->accel);
  cli::add_json_options(*sub, command->json, "the keys of the README's render table");
  sub->callback([command] { run(*command); });
}

}  // namespace splitray::app

// splitray view [SCENE]: the hybrid GPU + CPU renderer (paper 002) in a window, with a mouse
// and keyboard camera, toggles, an overlay of per-pass times and screenshots; `--frames`
// plays an animation rebuilt every frame by predicted kd builds.
#include <fmt/core.h>

#include <filesystem>
#include <memory>

#include "commands.hpp"
#include "file_options.hpp"
#include "json_output.hpp"
#include "options.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/image.hpp"
#include "splitray/io/frames.hpp"
#include "splitray/io/load_scene.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/render/default_scene.hpp"
#if SPLITRAY_HAS_RENDER_GL
#include "splitray/render_gl/viewer.hpp"
#endif

namespace splitray::app {

namespace {

struct ViewCommand {
  std::string scene;                // empty = built-in default scene
  std::vector<std::string> frames;  // animation
  std::string camera;
  int width = 1024, height = 768;
  int max_depth = 5;
  int blur_kernel = 5;
  int shadow_map_size = 2048;
  bool no_refine = false, no_reflections = false, sequential = false, no_overlay = false;
  std::string predictor = "kalman";
  std::string screenshot = "splitray-view.png";
  int exit_after = 0;
  AccelOptions accel;
  cli::JsonOutput json;
};

void run(const ViewCommand& command) {
#if SPLITRAY_HAS_RENDER_GL
  check_image_path(command.screenshot);  // before the window opens
  if (!command.scene.empty() && !command.frames.empty())
    throw Error("--frames", "give either a SCENE or --frames, not both");
  ViewerOptions options;
  HybridOptions& h = options.hybrid;
  h.width = command.width;
  h.height = command.height;
  h.max_depth = command.max_depth;
  h.accel = command.accel.accel;
  h.build = command.accel.build;
  h.blur_kernel = command.blur_kernel;
  h.shadow_map_size = command.shadow_map_size;
  h.refine_shadows = !command.no_refine;
  h.secondary = !command.no_reflections;
  h.interleaved = !command.sequential;
  options.overlay = !command.no_overlay;
  options.screenshot = command.screenshot;
  options.exit_after = command.exit_after;
  Scene scene;
  if (!command.frames.empty()) {
    if (h.build.builder.empty()) h.build.builder = "golden";  // what the predictions steer
    options.predictor.kind = parse_predictor_kind(command.predictor);
    fmt::print(stderr, "splitray view: loading the animation ...\n");
    const FrameSequence sequence(command.frames);
    options.frames = load_frames(sequence);
    // BART scenes: their materials, lights and camera path; others one flat-shaded mesh.
    if (auto aff = sequence.scene()) {
      scene = std::move(*aff);
      for (std::size_t i = 0; i < options.frames.size(); ++i)
        options.frame_cameras.push_back(*sequence.camera(i));
    } else {
      scene = animation_scene(options.frames.front());
    }
  } else {
    scene = command.scene.empty() ? default_scene() : load_scene(command.scene);
  }
  for (const std::string& warning : scene.warnings) cli::warn(warning);
  if (!command.camera.empty()) {
    const float vfov = scene.camera ? scene.camera->vfov_degrees : Camera{}.vfov_degrees;
    options.camera = to_camera(parse_camera(command.camera), vfov);
  }
  const ViewerSummary summary = run_viewer(scene, options);
  cli::emit_json(command.json, {{"frames_shown", summary.frames},
                                {"fps", summary.fps},
                                {"gl_renderer", summary.gl_renderer},
                                {"triangles", summary.triangles},
                                {"lights", summary.lights},
                                {"screenshot", options.exit_after > 0 ? command.screenshot : ""}});
#else
  (void)command;
  throw Error("view", "this splitray was built without OpenGL (SPLITRAY_WITH_GL=OFF)");
#endif
}

}  // namespace

void add_view_command(CLI::App& app) {
  auto command = std::make_shared<ViewCommand>();
  CLI::App* sub = app.add_subcommand(
      "view",
      "Interactive window of the hybrid GPU + CPU renderer (OpenGL 4.5; without a display run "
      "it under xvfb-run -a). Mouse: left drag orbit, right drag pan, wheel zoom; WASD/QE move; "
      "R shadow refinement, M reflections, I interleaving, O overlay, P screenshot, Space pause "
      "the animation, Home reset the camera, Esc quit");
  sub->add_option("SCENE", command->scene,
                  "Mesh file or JSON scene file; without it (and without --frames) the built-in "
                  "default scene");
  sub->add_option("--frames", command->frames,
                  "An animation (files, glob, printf pattern, folder, MD2 or BART .aff) played "
                  "with predicted kd rebuilds every frame (BART scenes along their camera path "
                  "until the camera is moved)");
  sub->add_option("--predictor", command->predictor, "Split predictor of the animation's rebuilds")
      ->check(CLI::IsMember({"kalman", "wiener", "none"}));
  sub->add_option("-W,--width", command->width, "Window width in pixels")
      ->check(CLI::Range(16, 8192));
  sub->add_option("-H,--height", command->height, "Window height in pixels")
      ->check(CLI::Range(16, 8192));
  add_camera_option(*sub, command->camera)
      ->description("Start camera EX,EY,EZ,TX,TY,TZ[,FOV] (default: the scene's, or framed)");
  sub->add_option("-d,--max-depth", command->max_depth, "Reflection and refraction bounces")
      ->check(CLI::Range(0, 64));
  sub->add_option("--blur-kernel", command->blur_kernel,
                  "K of the KxK blur marking shadow boundaries (odd)");
  sub->add_option("--shadow-map-size", command->shadow_map_size, "Shadow map texels per side");
  sub->add_flag("--no-refine", command->no_refine, "Start with shadow-boundary refinement off");
  sub->add_flag("--no-reflections", command->no_reflections,
                "Start with reflection/refraction rays off");
  sub->add_flag("--sequential", command->sequential, "Start with the passes strictly in sequence");
  sub->add_flag("--no-overlay", command->no_overlay, "Start without the text overlay");
  sub->add_option(
      "--screenshot", command->screenshot,
      "Image the screenshot key writes (atomically; the rendered frame without overlay; "
      ".png, .exr or .pfm)");
  sub->add_option("--exit-after", command->exit_after,
                  "Show this many frames, write the last one to --screenshot and exit (tests)")
      ->check(CLI::NonNegativeNumber);
  add_accel_options(*sub, command->accel);
  cli::add_json_options(*sub, command->json,
                        "at exit: frames_shown, fps, gl_renderer, triangles, lights, screenshot");
  cli::input_files(sub->get_option("SCENE"));
  cli::output_file(sub->get_option("--screenshot"));
  sub->callback([command] { run(*command); });
}

}  // namespace splitray::app

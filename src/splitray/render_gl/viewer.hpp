#pragma once
// `splitray view`: the hybrid renderer in a GLFW window (OpenGL 4.5 core) with a mouse and
// keyboard camera, toggles for shadow refinement, reflections and interleaving, an overlay
// with fps and per-pass times, screenshots, and animations rebuilt by predicted kd builds.
#include <optional>
#include <string>
#include <vector>

#include "splitray/accel/predict/split_predictor.hpp"
#include "splitray/core/scene.hpp"
#include "splitray/render_gl/hybrid.hpp"

namespace splitray {

struct ViewerOptions {
  HybridOptions hybrid;                          // width and height are the window's
  std::optional<Camera> camera;                  // default: the scene's, or one framing it
  std::string screenshot = "splitray-view.png";  // the screenshot key (P, F12) writes here
  int exit_after = 0;  // > 0: show this many frames, save the screenshot, exit
  bool overlay = true;
  // Animation (`--frames`): one triangle soup per frame, same count and order; rebuilt every
  // frame by the kd builder predicted from the previous frames' splits.
  std::vector<std::vector<Triangle>> frames;
  // The camera of each frame (BART's camera paths), followed until the user moves the camera;
  // empty: the camera stays where the user puts it.
  std::vector<Camera> frame_cameras;
  PredictorConfig predictor;
};

// What a session showed, for `view --json`.
struct ViewerSummary {
  int frames = 0;           // frames shown
  double fps = 0;           // smoothed frames per second at the end
  std::string gl_renderer;  // GL_RENDERER of the window's context
  std::size_t triangles = 0, lights = 0;
};

// Runs the window until it is closed (Esc, Q) or exit_after frames were shown. Throws Error
// with a clear message when there is no display or no OpenGL 4.5 core context.
ViewerSummary run_viewer(const Scene& scene, const ViewerOptions& options);

// The scene of an animation: frame 0 as one flat-shaded mesh, a light and a framed camera.
Scene animation_scene(const std::vector<Triangle>& first_frame);

}  // namespace splitray

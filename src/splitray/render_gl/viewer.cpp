#include "splitray/render_gl/viewer.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "splitray/render_gl/gl_api.hpp"
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include "splitray/accel/kd/coherent_builder.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/render_gl/gl_context.hpp"
#include "splitray/render_gl/gl_util.hpp"
#include "splitray/render_gl/overlay.hpp"

namespace splitray {

namespace {

constexpr const char* kWhere = "view";

std::string& glfw_message() {
  static std::string message;
  return message;
}

// GLFW and its window; glfwTerminate on every way out.
class Window {
 public:
  Window(int width, int height, const std::string& title) {
    glfwSetErrorCallback([](int, const char* text) { glfw_message() = text ? text : ""; });
    if (!glfwInit())
      throw Error(kWhere,
                  "cannot open a window (" + glfw_message() +
                      "); without a display run it under Xvfb: xvfb-run -a splitray view ...");
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_RESIZABLE, GLFW_FALSE);
    window_ = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
    if (!window_) {
      glfwTerminate();
      throw Error(kWhere, "no OpenGL 4.5 core context for a window (" + glfw_message() + ")");
    }
    glfwMakeContextCurrent(window_);
    glfwSwapInterval(0);
  }
  ~Window() {
    glfwDestroyWindow(window_);
    glfwTerminate();
  }
  Window(const Window&) = delete;
  Window& operator=(const Window&) = delete;
  GLFWwindow* get() const { return window_; }

 private:
  GLFWwindow* window_ = nullptr;
};

// The camera as yaw/pitch/distance around a target. Until the user moves it, the original
// camera is used unchanged, so that a still view matches a headless render bit for bit.
struct Controls {
  Camera original, camera;
  bool moved = false;
  float yaw = 0, pitch = 0, distance = 1, speed = 1;
  double mouse_x = 0, mouse_y = 0;
  bool orbit = false, pan = false;
  // Toggles and requests from the keyboard, handled by the frame loop.
  bool toggle_refine = false, toggle_secondary = false, toggle_interleave = false;
  bool toggle_overlay = false, toggle_pause = false, screenshot = false;

  explicit Controls(const Camera& c, float scene_size) : original(c), camera(c) {
    const Vec3 d = c.eye - c.target;
    distance = std::max(length(d), 1e-4f);
    yaw = std::atan2(d.x, d.z);
    pitch = std::asin(std::clamp(d.y / distance, -1.0f, 1.0f));
    speed = std::max(scene_size, 1e-3f) * 0.4f;
  }
  void update_eye() {
    moved = true;
    pitch = std::clamp(pitch, -1.55f, 1.55f);
    const Vec3 d{std::cos(pitch) * std::sin(yaw), std::sin(pitch), std::cos(pitch) * std::cos(yaw)};
    camera.eye = camera.target + d * distance;
  }
  Vec3 forward() const { return normalize(camera.target - camera.eye); }
  Vec3 right() const { return normalize(cross(forward(), camera.up)); }
  void move(const Vec3& by) {
    camera.eye += by;
    camera.target += by;
    moved = true;
  }
};

Controls& controls_of(GLFWwindow* w) {
  return *static_cast<Controls*>(glfwGetWindowUserPointer(w));
}

void install_callbacks(GLFWwindow* window) {
  glfwSetKeyCallback(window, [](GLFWwindow* w, int key, int, int action, int) {
    if (action != GLFW_PRESS) return;
    Controls& c = controls_of(w);
    switch (key) {
      case GLFW_KEY_ESCAPE:
        glfwSetWindowShouldClose(w, GLFW_TRUE);
        break;
      case GLFW_KEY_R:
        c.toggle_refine = true;
        break;
      case GLFW_KEY_M:
        c.toggle_secondary = true;
        break;
      case GLFW_KEY_I:
        c.toggle_interleave = true;
        break;
      case GLFW_KEY_O:
        c.toggle_overlay = true;
        break;
      case GLFW_KEY_SPACE:
        c.toggle_pause = true;
        break;
      case GLFW_KEY_P:
      case GLFW_KEY_F12:
        c.screenshot = true;
        break;
      case GLFW_KEY_HOME: {
        const Camera original = c.original;
        const float size = c.speed / 0.4f;
        c = Controls(original, size);
        break;
      }
      default:
        break;
    }
  });
  glfwSetMouseButtonCallback(window, [](GLFWwindow* w, int button, int action, int) {
    Controls& c = controls_of(w);
    glfwGetCursorPos(w, &c.mouse_x, &c.mouse_y);
    if (button == GLFW_MOUSE_BUTTON_LEFT) c.orbit = action == GLFW_PRESS;
    if (button == GLFW_MOUSE_BUTTON_RIGHT || button == GLFW_MOUSE_BUTTON_MIDDLE)
      c.pan = action == GLFW_PRESS;
  });
  glfwSetCursorPosCallback(window, [](GLFWwindow* w, double x, double y) {
    Controls& c = controls_of(w);
    const float dx = static_cast<float>(x - c.mouse_x), dy = static_cast<float>(y - c.mouse_y);
    c.mouse_x = x;
    c.mouse_y = y;
    if (c.orbit) {
      c.yaw -= dx * 0.005f;
      c.pitch += dy * 0.005f;
      c.update_eye();
    } else if (c.pan) {
      const float scale = c.distance * 0.002f;
      const Vec3 up = normalize(cross(c.right(), c.forward()));
      c.move(c.right() * (-dx * scale) + up * (dy * scale));
    }
  });
  glfwSetScrollCallback(window, [](GLFWwindow* w, double, double dy) {
    Controls& c = controls_of(w);
    c.distance *= std::pow(0.9f, static_cast<float>(dy));
    c.update_eye();
  });
}

// WASD along the view, Q/E down and up, Shift faster.
void keyboard_motion(GLFWwindow* w, Controls& c, float dt) {
  const auto down = [&](int key) { return glfwGetKey(w, key) == GLFW_PRESS; };
  const float step = c.speed * dt * (down(GLFW_KEY_LEFT_SHIFT) ? 4.0f : 1.0f);
  Vec3 by{0};
  if (down(GLFW_KEY_W)) by += c.forward() * step;
  if (down(GLFW_KEY_S)) by -= c.forward() * step;
  if (down(GLFW_KEY_D)) by += c.right() * step;
  if (down(GLFW_KEY_A)) by -= c.right() * step;
  if (down(GLFW_KEY_E)) by += c.camera.up * step;
  if (down(GLFW_KEY_Q)) by -= c.camera.up * step;
  if (by != Vec3{0}) c.move(by);
}

const char* on_off(bool b) { return b ? "on" : "off"; }

}  // namespace

Scene animation_scene(const std::vector<Triangle>& first_frame) {
  if (first_frame.empty()) throw Error("--frames", "the first frame has no triangles");
  Mesh mesh;
  mesh.name = "animation";
  mesh.positions.reserve(first_frame.size() * 3);
  for (const Triangle& t : first_frame) {
    const auto base = static_cast<std::uint32_t>(mesh.positions.size());
    for (int k = 0; k < 3; ++k) mesh.positions.push_back(t.vertex(k));
    mesh.faces.push_back({base, base + 1, base + 2});
  }
  return scene_from_mesh(std::move(mesh));  // no vertex normals: flat, as later frames
}

ViewerSummary run_viewer(const Scene& scene, const ViewerOptions& options) {
  const bool animated = options.frames.size() > 1;
  if (animated && options.hybrid.accel != "kd")
    throw Error("--accel", "animations are rebuilt by the coherent kd rebuild: use --accel kd");
  const HybridOptions& ho = options.hybrid;
  Window window(ho.width, ho.height, "splitray view");
  GLint major = 0, minor = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  if (major * 10 + minor < 45)
    throw Error(kWhere,
                fmt::format("needs OpenGL 4.5, the window's context has {}.{}", major, minor));
  const std::string renderer_name = gl::renderer_name();
  ThreadLimit limit(ho.build.threads);

  const Camera start = options.camera                   ? *options.camera
                       : !options.frame_cameras.empty() ? options.frame_cameras.front()
                       : scene.camera                   ? *scene.camera
                                                        : Camera::frame(scene.bounds());
  HybridRenderer renderer(scene, ho, start);
  if (const std::string warning =
          coverage_warning(renderer.coverage(start), renderer.lights().size());
      !warning.empty())
    std::fprintf(stderr, "splitray: warning: %s\n", warning.c_str());
  const std::size_t triangles = renderer.accel_stats().prims;
  gl::Overlay overlay;
  const gl::Program present("fullscreen.vert.glsl", "present.frag.glsl");
  GLuint empty_vao = 0;
  glCreateVertexArrays(1, &empty_vao);
  glProgramUniform1i(present.id(), present.uniform("u_image"), 0);

  Controls controls(start, length(scene.bounds().extent()));
  glfwSetWindowUserPointer(window.get(), &controls);
  install_callbacks(window.get());

  BuildConfig golden = ho.build;  // the coherent rebuild's from-scratch builder
  golden.builder = "golden";
  KdCoherentBuilder coherent(golden, options.predictor);
  std::size_t animation_frame = 0;
  double build_ms = 0;
  bool paused = false, overlay_on = options.overlay;

  HybridFrame last;
  int shown = 0, submitted = 0;
  double fps = 0, present_ms = 0;
  Timer clock;
  double last_shown = 0, last_tick = 0;

  const auto save = [&](const std::string& path) {
    if (last.image.pixels.empty()) return;
    write_image(path, last.image);
    std::fprintf(stderr, "splitray view: saved %s (%d x %d)\n", path.c_str(), last.image.width,
                 last.image.height);
    std::fflush(stdout);
  };
  // Puts the finished frame (the renderer's last composite) on the screen with the overlay.
  const auto show = [&](HybridFrame&& frame) {
    const Timer timer;
    int fw = 0, fh = 0;
    glfwGetFramebufferSize(window.get(), &fw, &fh);
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glViewport(0, 0, fw, fh);
    glDisable(GL_DEPTH_TEST);
    present.use();
    glProgramUniform2f(present.id(), present.uniform("u_viewport"), static_cast<float>(fw),
                       static_cast<float>(fh));
    glBindTextureUnit(0, renderer.last_texture());
    glBindVertexArray(empty_vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    const double now = clock.ms();
    if (shown > 0) {
      const double interval = now - last_shown;
      fps = fps == 0 ? 1000.0 / interval : 0.8 * fps + 0.2 * 1000.0 / interval;
    }
    last_shown = now;
    const HybridOptions& o = renderer.options();
    if (overlay_on) {
      const auto& p = frame.pass_ms;
      std::vector<std::string> lines = {
          fmt::format("splitray view  {}x{}  {} triangles", ho.width, ho.height, triangles),
          "GL: " + renderer_name,
          fmt::format("{:.2f} fps  ({:.1f} ms per frame)", fps, fps > 0 ? 1000.0 / fps : 0.0),
          fmt::format("GPU: shadow map {:.1f}  ids+mask {:.1f}  blur {:.1f}  composite {:.1f} ms",
                      p[0], p[1], p[2], p[4]),
          fmt::format("CPU: ray pass {:.1f} ms, {} rays  present {:.1f} ms", p[3], frame.cpu_rays,
                      present_ms),
          fmt::format("     {} reflective + {} shadow-boundary pixels", frame.secondary_pixels,
                      frame.boundary_pixels),
          fmt::format("[R] refine shadows {}  [M] reflections {}  [I] interleaved {}",
                      on_off(o.refine_shadows), on_off(o.secondary), on_off(o.interleaved)),
      };
      if (animated)
        lines.push_back(fmt::format(
            "animation frame {}/{}  coherent kd rebuild {:.1f} ms  [Space] {}", animation_frame + 1,
            options.frames.size(), build_ms, paused ? "play" : "pause"));
      lines.push_back("mouse: left orbit, right pan, wheel zoom  WASD/QE move");
      lines.push_back("[P] screenshot  [Home] reset camera  [O] overlay  [Esc] quit");
      overlay.draw(lines, fw, fh);
    }
    glfwSwapBuffers(window.get());
    gl::check_error("presenting a frame");
    last = std::move(frame);
    ++shown;
    present_ms = timer.ms();
    glfwSetWindowTitle(window.get(), fmt::format("splitray view - {:.2f} fps", fps).c_str());
  };

  while (!glfwWindowShouldClose(window.get())) {
    glfwPollEvents();
    const double now = clock.ms();
    const float dt = static_cast<float>(std::min(now - last_tick, 250.0) * 1e-3);
    last_tick = now;
    if (controls.toggle_refine || controls.toggle_secondary || controls.toggle_interleave) {
      if (auto f = renderer.finish()) show(std::move(*f));  // options change between frames only
      HybridOptions& o = renderer.options();
      if (controls.toggle_refine) o.refine_shadows = !o.refine_shadows;
      if (controls.toggle_secondary) o.secondary = !o.secondary;
      if (controls.toggle_interleave) o.interleaved = !o.interleaved;
      controls.toggle_refine = controls.toggle_secondary = controls.toggle_interleave = false;
    }
    if (controls.toggle_overlay) overlay_on = !overlay_on;
    if (controls.toggle_pause) paused = !paused;
    controls.toggle_overlay = controls.toggle_pause = false;
    keyboard_motion(window.get(), controls, dt);

    // Frame 0 is the scene itself; every later frame is rebuilt from the predictions.
    if (animated && !paused && submitted > 0) {
      animation_frame = (animation_frame + 1) % options.frames.size();
      if (animation_frame == 0) coherent.reset();  // the loop jumps back: a fresh tree
      const Timer build_timer;
      CoherentFrameStats stats;
      renderer.set_triangles(options.frames[animation_frame], [&](std::span<const Triangle> tris) {
        return std::unique_ptr<Accel>(coherent.next_frame(tris, stats));
      });
      build_ms = build_timer.ms();
    }
    const Camera camera = controls.moved                  ? controls.camera
                          : options.frame_cameras.empty() ? controls.original
                                                          : options.frame_cameras[animation_frame];
    ++submitted;
    if (auto f = renderer.submit(camera)) show(std::move(*f));
    if (controls.screenshot) {
      controls.screenshot = false;
      save(options.screenshot);
    }
    if (options.exit_after > 0 && shown >= options.exit_after) break;
  }
  if (auto f = renderer.finish()) {
    if (options.exit_after <= 0 || shown < options.exit_after) show(std::move(*f));
  }
  if (options.exit_after > 0 && !options.screenshot.empty()) save(options.screenshot);
  glDeleteVertexArrays(1, &empty_vao);
  return {shown, fps, renderer_name, triangles, renderer.lights().size()};
}

}  // namespace splitray

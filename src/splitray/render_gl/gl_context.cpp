#include "splitray/render_gl/gl_context.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>

#include "splitray/core/errors.hpp"
#include "splitray/render_gl/gl_api.hpp"

namespace splitray::gl {

namespace {

constexpr const char* kWhere = "OpenGL (--mode hybrid)";

[[noreturn]] void fail(const std::string& step) {
  throw Error(kWhere, step + " failed (EGL error 0x" +
                          [] {
                            char buf[16];
                            std::snprintf(buf, sizeof buf, "%04x", eglGetError());
                            return std::string(buf);
                          }() +
                          "); no usable OpenGL 4.5 on this machine");
}

EGLDisplay open_display() {
  const char* extensions = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (extensions && std::string(extensions).find("EGL_MESA_platform_surfaceless") != std::string::npos) {
    EGLDisplay display = eglGetPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (display != EGL_NO_DISPLAY) return display;
  }
  return eglGetDisplay(EGL_DEFAULT_DISPLAY);
}

}  // namespace

EglContext::EglContext() {
  EGLDisplay display = open_display();
  if (display == EGL_NO_DISPLAY) fail("opening an EGL display");
  EGLint major = 0, minor = 0;
  if (!eglInitialize(display, &major, &minor)) fail("eglInitialize");
  display_ = display;
  if (!eglBindAPI(EGL_OPENGL_API)) fail("binding the OpenGL API");
  // Surfaceless displays offer pbuffer configs (the default asks for windows); without any,
  // a config-less context (EGL_KHR_no_config_context) still renders into framebuffer objects.
  const EGLint config_attributes[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE,
                                      EGL_OPENGL_BIT, EGL_NONE};
  EGLConfig config = EGL_NO_CONFIG_KHR;
  EGLint configs = 0;
  if (!eglChooseConfig(display, config_attributes, &config, 1, &configs) || configs < 1)
    config = EGL_NO_CONFIG_KHR;
  const EGLint context_attributes[] = {EGL_CONTEXT_MAJOR_VERSION, 4,
                                       EGL_CONTEXT_MINOR_VERSION, 5,
                                       EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                       EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                       EGL_NONE};
  context_ = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attributes);
  if (context_ == EGL_NO_CONTEXT) {
    context_ = nullptr;
    fail("creating an OpenGL 4.5 core context");
  }
  make_current();
}

EglContext::~EglContext() {
  if (!display_) return;
  eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  if (context_) eglDestroyContext(display_, context_);
  eglTerminate(display_);
}

void EglContext::make_current() {
  if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
    fail("making the context current");
}

std::string renderer_name() {
  const auto* name = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  return name ? name : "unknown";
}

}  // namespace splitray::gl

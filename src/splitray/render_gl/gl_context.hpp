#pragma once
// A headless OpenGL 4.5 core context through EGL (Mesa's surfaceless platform, or the default
// display when that is missing). On a machine without any usable OpenGL the constructor throws
// splitray::Error naming the step that failed; it never crashes.
#include <string>

namespace splitray::gl {

class EglContext {
 public:
  EglContext();  // creates the context and makes it current on this thread
  ~EglContext();
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;

  void make_current();

 private:
  void* display_ = nullptr;
  void* context_ = nullptr;
};

// GL_RENDERER of the current context, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
std::string renderer_name();

}  // namespace splitray::gl

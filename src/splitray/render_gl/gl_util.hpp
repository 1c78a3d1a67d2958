#pragma once
// Small RAII helpers over OpenGL objects: programs from the embedded shaders, textures and
// framebuffers. Every GL error surfaces as splitray::Error.
#include <string>
#include <vector>

#include "splitray/render_gl/gl_api.hpp"

namespace splitray::gl {

// A linked program of embedded shaders (file names under shaders/); each gets the version
// line, common.glsl and the `includes` prepended.
class Program {
 public:
  Program() = default;
  Program(const std::string& vertex, const std::string& fragment,
          const std::vector<std::string>& includes = {});
  ~Program();
  Program(Program&& o) noexcept : id_(o.id_) { o.id_ = 0; }
  Program& operator=(Program&& o) noexcept;
  Program(const Program&) = delete;
  Program& operator=(const Program&) = delete;

  GLuint id() const { return id_; }
  GLint uniform(const char* name) const { return glGetUniformLocation(id_, name); }
  void use() const { glUseProgram(id_); }

 private:
  GLuint id_ = 0;
};

// Throws Error naming `what` if glGetError reports a problem.
void check_error(const char* what);

GLuint make_texture_2d(GLenum internal_format, int width, int height, GLenum filter = GL_NEAREST);

}  // namespace splitray::gl

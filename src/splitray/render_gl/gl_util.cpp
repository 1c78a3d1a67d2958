#include "splitray/render_gl/gl_util.hpp"

#include <string_view>

#include "splitray/core/errors.hpp"
#include "splitray/render_gl/shaders.hpp"

namespace splitray::gl {

namespace {

GLuint compile(GLenum type, const std::string& name, const std::vector<std::string>& includes) {
  std::string text = "#version 450 core\n";
  text += shader_source("common.glsl");
  for (const std::string& include : includes) text += shader_source(include);
  text += "#line 1\n";
  text += shader_source(name);
  const GLuint shader = glCreateShader(type);
  const char* source = text.c_str();
  glShaderSource(shader, 1, &source, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetShaderInfoLog(shader, sizeof log, nullptr, log);
    glDeleteShader(shader);
    throw Error("shaders/" + name, std::string("does not compile: ") + log);
  }
  return shader;
}

}  // namespace

Program::Program(const std::string& vertex, const std::string& fragment,
                 const std::vector<std::string>& includes) {
  const GLuint vs = compile(GL_VERTEX_SHADER, vertex, includes);
  const GLuint fs = compile(GL_FRAGMENT_SHADER, fragment, includes);
  id_ = glCreateProgram();
  glAttachShader(id_, vs);
  glAttachShader(id_, fs);
  glLinkProgram(id_);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(id_, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetProgramInfoLog(id_, sizeof log, nullptr, log);
    throw Error("shaders/" + vertex + " + " + fragment, std::string("do not link: ") + log);
  }
}

Program::~Program() {
  if (id_) glDeleteProgram(id_);
}

Program& Program::operator=(Program&& o) noexcept {
  if (this != &o) {
    if (id_) glDeleteProgram(id_);
    id_ = o.id_;
    o.id_ = 0;
  }
  return *this;
}

void check_error(const char* what) {
  const GLenum error = glGetError();
  if (error != GL_NO_ERROR) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "0x%04x", error);
    throw Error(std::string("OpenGL: ") + what, std::string("GL error ") + buf);
  }
}

GLuint make_texture_2d(GLenum internal_format, int width, int height, GLenum filter) {
  GLuint texture = 0;
  glCreateTextures(GL_TEXTURE_2D, 1, &texture);
  glTextureStorage2D(texture, 1, internal_format, width, height);
  glTextureParameteri(texture, GL_TEXTURE_MIN_FILTER, filter);
  glTextureParameteri(texture, GL_TEXTURE_MAG_FILTER, filter);
  glTextureParameteri(texture, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(texture, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return texture;
}

}  // namespace splitray::gl

#pragma once
// Text over the viewer's image: lines of ASCII in stb_easy_font's bitmap-free vector font,
// drawn as triangles on a translucent panel in the top-left corner.
#include <string>
#include <vector>

#include "splitray/render_gl/gl_util.hpp"

namespace splitray::gl {

class Overlay {
 public:
  Overlay();  // needs a current OpenGL 4.5 context
  ~Overlay();
  Overlay(const Overlay&) = delete;
  Overlay& operator=(const Overlay&) = delete;

  // Draws `lines` into the bound framebuffer of `width` x `height` pixels.
  void draw(const std::vector<std::string>& lines, int width, int height);

 private:
  Program program_;
  GLuint vao_ = 0, vbo_ = 0;
};

}  // namespace splitray::gl

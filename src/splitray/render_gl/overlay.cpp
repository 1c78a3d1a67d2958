#include "splitray/render_gl/overlay.hpp"

#include <algorithm>
#include <cstring>

// stb_easy_font is header-only with static functions (no implementation macro to define).
#include <stb/stb_easy_font.h>

namespace splitray::gl {

namespace {

struct QuadVertex {  // stb_easy_font's output layout
  float x, y, z;
  unsigned char color[4];
};

constexpr float kMaxScale = 2.0f, kMargin = 8.0f, kLineHeight = 12.0f;

void add_rect(std::vector<float>& out, float x0, float y0, float x1, float y1) {
  const float v[] = {x0, y0, x1, y0, x1, y1, x0, y0, x1, y1, x0, y1};
  out.insert(out.end(), std::begin(v), std::end(v));
}

}  // namespace

Overlay::Overlay() : program_("overlay.vert.glsl", "overlay.frag.glsl") {
  glCreateVertexArrays(1, &vao_);
  glCreateBuffers(1, &vbo_);
  glVertexArrayVertexBuffer(vao_, 0, vbo_, 0, 2 * sizeof(float));
  glEnableVertexArrayAttrib(vao_, 0);
  glVertexArrayAttribFormat(vao_, 0, 2, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayAttribBinding(vao_, 0, 0);
  check_error("creating the overlay");
}

Overlay::~Overlay() {
  glDeleteBuffers(1, &vbo_);
  glDeleteVertexArrays(1, &vao_);
}

void Overlay::draw(const std::vector<std::string>& lines, int width, int height) {
  // Text triangles first, the panel behind them last in the buffer (drawn first).
  std::vector<float> text;
  std::vector<QuadVertex> quads(4 * 2000);
  float widest = 0;
  for (std::size_t k = 0; k < lines.size(); ++k) {
    std::vector<char> line(lines[k].begin(), lines[k].end());
    line.push_back('\0');
    widest = std::max(widest, static_cast<float>(stb_easy_font_width(line.data())));
    const int n = stb_easy_font_print(0, kLineHeight * static_cast<float>(k), line.data(), nullptr,
                                      quads.data(), static_cast<int>(quads.size() * sizeof(QuadVertex)));
    for (int q = 0; q < n; ++q) {
      const QuadVertex* v = &quads[static_cast<std::size_t>(q) * 4];
      add_rect(text, v[0].x, v[0].y, v[2].x, v[2].y);
    }
  }
  std::vector<float> all;
  add_rect(all, -4, -4, widest + 4, kLineHeight * static_cast<float>(lines.size()) + 2);
  all.insert(all.end(), text.begin(), text.end());
  glNamedBufferData(vbo_, static_cast<GLsizeiptr>(all.size() * sizeof(float)), all.data(), GL_STREAM_DRAW);

  glDisable(GL_DEPTH_TEST);
  glEnable(GL_BLEND);
  glBlendFunc(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA);
  program_.use();
  const GLuint p = program_.id();
  glProgramUniform2f(p, program_.uniform("u_screen"), static_cast<float>(width), static_cast<float>(height));
  // As large as fits the window's width, between 1x and 2x the font's pixels.
  const float fit = (static_cast<float>(width) - 2 * kMargin) / std::max(widest + 8, 1.0f);
  glProgramUniform1f(p, program_.uniform("u_scale"), std::clamp(fit, 1.0f, kMaxScale));
  glProgramUniform2f(p, program_.uniform("u_offset"), kMargin, kMargin);
  glBindVertexArray(vao_);
  glProgramUniform4f(p, program_.uniform("u_color"), 0.0f, 0.0f, 0.0f, 0.55f);
  glDrawArrays(GL_TRIANGLES, 0, 6);
  glProgramUniform4f(p, program_.uniform("u_color"), 1.0f, 1.0f, 0.85f, 1.0f);
  glDrawArrays(GL_TRIANGLES, 6, static_cast<GLsizei>(text.size() / 2));
  glDisable(GL_BLEND);
  check_error("drawing the overlay");
}

}  // namespace splitray::gl

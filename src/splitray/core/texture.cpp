#include "splitray/core/texture.hpp"

#include <cmath>

namespace splitray {

namespace {

// The coordinate folded into the range its wrap mode reads ([0, 1) repeat, [0, 2) mirror,
// a little beyond [0, 1] clamp), so that the texel index below fits an int.
float fold(float c, WrapMode mode) {
  if (!std::isfinite(c)) return 0;
  switch (mode) {
    case WrapMode::repeat:
      return c - std::floor(c);
    case WrapMode::mirror:
      return c - 2 * std::floor(c * 0.5f);
    case WrapMode::clamp:
      return std::fmin(std::fmax(c, -1.0f), 2.0f);
  }
  return c;
}

int wrap_index(int i, int n, WrapMode mode) {
  switch (mode) {
    case WrapMode::repeat:
      return ((i % n) + n) % n;
    case WrapMode::mirror: {
      const int m = ((i % (2 * n)) + 2 * n) % (2 * n);
      return m < n ? m : 2 * n - 1 - m;
    }
    case WrapMode::clamp:
      return i < 0 ? 0 : (i >= n ? n - 1 : i);
  }
  return 0;
}

}  // namespace

Vec3 Texture::sample(Vec2 uv) const {
  if (width <= 0 || height <= 0) return Vec3{1};
  const float x = fold(uv.x, wrap_u) * static_cast<float>(width) - 0.5f;
  const float y = (1 - fold(uv.y, wrap_v)) * static_cast<float>(height) - 0.5f;
  const float x0 = std::floor(x), y0 = std::floor(y);
  const float fx = x - x0, fy = y - y0;
  const int ix = static_cast<int>(x0), iy = static_cast<int>(y0);
  const int xa = wrap_index(ix, width, wrap_u), xb = wrap_index(ix + 1, width, wrap_u);
  const int ya = wrap_index(iy, height, wrap_v), yb = wrap_index(iy + 1, height, wrap_v);
  const Vec3 top = at(xa, ya) * (1 - fx) + at(xb, ya) * fx;
  const Vec3 bottom = at(xa, yb) * (1 - fx) + at(xb, yb) * fx;
  return top * (1 - fy) + bottom * fy;
}

}  // namespace splitray

// Image textures as core/texture.cpp samples them: bilinear between the four texels around
// the coordinates, texel centres at (i + 0.5) / size, v = 0 at the bottom row, each axis
// wrapped by its mode (0 repeat, 1 clamp, 2 mirror). Texels are linear RGB, top row first.
struct TextureGpu {
  int width, height, offset, wrap;  // wrap: u's mode | v's mode << 2
};
layout(std430, binding = 1) readonly buffer Textures { TextureGpu textures[]; };
layout(std430, binding = 2) readonly buffer Texels { vec4 texels[]; };

float fold_coordinate(float c, int mode) {
  if (isnan(c) || isinf(c)) return 0.0;
  if (mode == 0) return c - floor(c);
  if (mode == 2) return c - 2.0 * floor(c * 0.5);
  return min(max(c, -1.0), 2.0);
}
// i lies in [-n - 1, 2n] after folding, so no modulo of negative numbers is needed.
int wrap_index(int i, int n, int mode) {
  if (mode == 0) return i < 0 ? i + n : (i >= n ? i - n : i);
  if (mode == 2) {
    int m = i < 0 ? i + 2 * n : (i >= 2 * n ? i - 2 * n : i);
    return m < n ? m : 2 * n - 1 - m;
  }
  return clamp(i, 0, n - 1);
}
vec3 texel(TextureGpu t, int x, int y) { return texels[t.offset + y * t.width + x].rgb; }
vec3 sample_texture(int index, vec2 uv) {
  TextureGpu t = textures[index];
  int mu = t.wrap & 3, mv = (t.wrap >> 2) & 3;
  float x = fold_coordinate(uv.x, mu) * float(t.width) - 0.5;
  float y = (1.0 - fold_coordinate(uv.y, mv)) * float(t.height) - 0.5;
  float x0 = floor(x), y0 = floor(y);
  float fx = x - x0, fy = y - y0;
  int ix = int(x0), iy = int(y0);
  int xa = wrap_index(ix, t.width, mu), xb = wrap_index(ix + 1, t.width, mu);
  int ya = wrap_index(iy, t.height, mv), yb = wrap_index(iy + 1, t.height, mv);
  vec3 top = texel(t, xa, ya) * (1.0 - fx) + texel(t, xb, ya) * fx;
  vec3 bottom = texel(t, xa, yb) * (1.0 - fx) + texel(t, xb, yb) * fx;
  return top * (1.0 - fy) + bottom * fy;
}

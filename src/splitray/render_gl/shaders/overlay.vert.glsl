// The viewer's overlay: text quads in window pixels (top-left origin), scaled by u_scale.
layout(location = 0) in vec2 a_position;
uniform vec2 u_screen;
uniform float u_scale;
uniform vec2 u_offset;
void main() {
  vec2 p = a_position * u_scale + u_offset;
  gl_Position = vec4(p.x / u_screen.x * 2.0 - 1.0, 1.0 - p.y / u_screen.y * 2.0, 0.0, 1.0);
}

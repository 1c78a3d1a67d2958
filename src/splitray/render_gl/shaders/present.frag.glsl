// The viewer: the linear image to the window in sRGB, scaled to the window's framebuffer.
uniform sampler2D u_image;
uniform vec2 u_viewport;
out vec4 o_color;
void main() {
  vec3 c = clamp(texture(u_image, gl_FragCoord.xy / u_viewport).rgb, 0.0, 1.0);
  vec3 srgb = mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(0.0031308, c));
  o_color = vec4(srgb, 1.0);
}

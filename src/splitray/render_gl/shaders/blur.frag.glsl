// Pass 3: a box blur of the shadow mask over a KxK kernel; a pixel whose blurred value lies
// strictly between 0 and 1 (or that a transparent caster shadows) is a shadow boundary.
uniform sampler2D u_mask;
uniform usampler2D u_ids;
uniform int u_radius;
out vec4 o_boundary;
void main() {
  ivec2 c = ivec2(gl_FragCoord.xy);
  ivec2 size = textureSize(u_mask, 0);
  vec4 center = texelFetch(u_mask, c, 0);
  if (texelFetch(u_ids, c, 0).r == 0u) { o_boundary = vec4(0.0); return; }
  vec4 sum = vec4(0.0);
  float n = 0.0;
  for (int dy = -u_radius; dy <= u_radius; ++dy)
    for (int dx = -u_radius; dx <= u_radius; ++dx) {
      ivec2 q = clamp(c + ivec2(dx, dy), ivec2(0), size - 1);
      if (texelFetch(u_ids, q, 0).r == 0u) continue;  // the background casts no shadow state
      sum += texelFetch(u_mask, q, 0);
      n += 1.0;
    }
  vec4 blurred = sum / max(n, 1.0);
  vec4 boundary = vec4(0.0);
  for (int i = 0; i < kMaxLights; ++i)
    boundary[i] = (center[i] == 0.5 || (blurred[i] > 0.001 && blurred[i] < 0.999)) ? 1.0 : 0.0;
  o_boundary = boundary;
}

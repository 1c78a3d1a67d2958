// Pass 2: the triangle id (+1, 0 = background) into an R32UI attachment, and the shadow-map
// test per light into the mask: 1 lit, 0 shadowed, 0.5 shadowed by a transparent caster
// (its exact transmission is left to the CPU).
in vec3 v_world;
in vec3 v_normal;
flat in vec3 v_geometric_normal;
flat in uint v_material;
uniform sampler2DShadow u_shadow_map[kMaxLights];
uniform sampler2D u_shadow_flag[kMaxLights];
uniform samplerCubeShadow u_shadow_cube[kMaxLights];
uniform samplerCube u_cube_flag[kMaxLights];
uniform mat4 u_light_matrix[kMaxLights];
uniform float u_light_range[kMaxLights];
uniform float u_normal_offset[kMaxLights];
layout(location = 0) out uint o_id;
layout(location = 1) out vec4 o_mask;
void main() {
  o_id = uint(gl_PrimitiveID) + 1u;
  vec3 ng = facing_geometric_normal(v_geometric_normal, v_world);
  vec4 mask = vec4(1.0);
  for (int i = 0; i < u_light_count; ++i) {
    vec3 l = to_light(i, v_world);
    if (dot(ng, l) <= 0.0) { mask[i] = 0.0; continue; }
    vec3 p = v_world + ng * u_normal_offset[i];
    float lit, transparent;
    if (u_light_kind[i] == 0) {
      vec3 d = p - u_light_position[i];
      lit = texture(u_shadow_cube[i], vec4(d, length(d) / u_light_range[i]));
      transparent = texture(u_cube_flag[i], d).r;
    } else {
      vec4 c = u_light_matrix[i] * vec4(p, 1.0);
      vec3 s = c.xyz / c.w * 0.5 + 0.5;
      if (any(lessThan(s, vec3(0.0))) || any(greaterThan(s, vec3(1.0)))) { lit = 1.0; transparent = 0.0; }
      else { lit = texture(u_shadow_map[i], s); transparent = texture(u_shadow_flag[i], s.xy).r; }
    }
    mask[i] = lit > 0.5 ? 1.0 : (transparent > 0.5 ? 0.5 : 0.0);
  }
  o_mask = mask;
}

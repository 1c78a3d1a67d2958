// Pass 5: Blinn-Phong of the primary hit (as render/shading.hpp computes it) weighted by the
// refined light visibility, plus the CPU's reflection and refraction contribution.
in vec3 v_world;
in vec3 v_normal;
flat in vec3 v_geometric_normal;
flat in uint v_material;
in vec2 v_uv;
uniform sampler2D u_visibility;  // per light, rgba = lights 0..3
uniform sampler2D u_cpu_color;
uniform vec3 u_ambient;
out vec4 o_color;
void main() {
  ivec2 c = ivec2(gl_FragCoord.xy);
  MaterialGpu m = materials[v_material];
  vec3 ng = facing_geometric_normal(v_geometric_normal, v_world);
  vec3 ns = normalize(v_normal);
  if (!(dot(ns, ns) > 0.5)) ns = ng;
  if (dot(ns, ng) < 0.0) ns = -ns;
  vec3 to_eye = normalize(u_eye - v_world);
  float share = m.diffuse_share.a;
  vec3 diffuse = m.diffuse_share.rgb;
  if (m.flags.y >= 0.0) diffuse *= sample_texture(int(m.flags.y), v_uv);
  vec3 color = u_ambient * (m.ambient.a > 0.0 ? m.ambient.rgb : diffuse) * share;
  vec4 visibility = texelFetch(u_visibility, c, 0);
  for (int i = 0; i < u_light_count; ++i) {
    vec3 l = to_light(i, v_world);
    if (dot(ng, l) <= 0.0) continue;
    float n_dot_l = dot(ns, l);
    if (n_dot_l <= 0.0) continue;
    vec3 radiance = u_light_radiance[i];
    if (u_light_kind[i] == 0 && u_light_falloff[i] > 0.0) {
      vec3 d = u_light_position[i] - v_world;
      radiance /= max(dot(d, d), 1e-12);
    }
    vec3 lc = diffuse * (share * n_dot_l);
    if (m.specular_shine.rgb != vec3(0.0)) {
      vec3 h = normalize(l + to_eye);
      lc += m.specular_shine.rgb * pow(max(dot(ns, h), 0.0), m.specular_shine.a);
    }
    color += lc * radiance * visibility[i];
  }
  o_color = vec4(color + texelFetch(u_cpu_color, c, 0).rgb, 1.0);
}

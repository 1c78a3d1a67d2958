// Pass 1: depth from the light (hardware depth for LiSPSM maps, distance / range for the
// cube maps of point lights) and whether the nearest caster is transparent.
in vec3 v_world;
in vec3 v_normal;
flat in vec3 v_geometric_normal;
flat in uint v_material;
uniform int u_cube;
uniform vec3 u_light_position;
uniform float u_range;
layout(location = 0) out float o_transparent;
void main() {
  if (u_cube != 0) gl_FragDepth = length(v_world - u_light_position) / u_range;
  o_transparent = materials[v_material].flags.x > 0.0 ? 1.0 : 0.0;
}

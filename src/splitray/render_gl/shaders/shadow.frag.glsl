// Pass 1: depth from the light (hardware depth, with polygon offset, for the LiSPSM maps of
// directional lights; distance / range for the cube maps of point lights, SHADOW_CUBE) and
// whether the nearest caster is transparent.
in vec3 v_world;
in vec3 v_normal;
flat in vec3 v_geometric_normal;
flat in uint v_material;
#ifdef SHADOW_CUBE
uniform vec3 u_light_position;
uniform float u_range;
#endif
layout(location = 0) out float o_transparent;
void main() {
#ifdef SHADOW_CUBE
  gl_FragDepth = length(v_world - u_light_position) / u_range;
#endif
  o_transparent = materials[v_material].flags.x > 0.0 ? 1.0 : 0.0;
}

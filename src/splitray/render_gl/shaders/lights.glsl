// Lights as the CPU sees them (render/shading.hpp): kind 0 point (1/d^2), 1 directional.
uniform int u_light_count;
uniform int u_light_kind[kMaxLights];
uniform vec3 u_light_position[kMaxLights];
uniform vec3 u_light_direction[kMaxLights];  // towards the light, unit (directional)
uniform vec3 u_light_radiance[kMaxLights];   // colour * intensity
uniform float u_light_falloff[kMaxLights];   // point lights: 1 = 1/d^2, 0 = none
uniform vec3 u_eye;

// The geometric normal turned towards the viewer, as the CPU tracer turns it to the ray.
vec3 facing_geometric_normal(vec3 ng, vec3 world) {
  ng = normalize(ng);
  return dot(ng, world - u_eye) < 0.0 ? ng : -ng;
}
vec3 to_light(int i, vec3 p) {
  return u_light_kind[i] == 1 ? u_light_direction[i] : normalize(u_light_position[i] - p);
}

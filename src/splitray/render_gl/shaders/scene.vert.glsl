// Every pass draws the triangle soup: world position, vertex normal, geometric normal and
// material id and texture coordinates per vertex, so that gl_PrimitiveID is the splitray triangle index.
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec3 a_geometric_normal;
layout(location = 3) in uint a_material;
layout(location = 4) in vec2 a_uv;
uniform mat4 u_matrix;
out vec3 v_world;
out vec3 v_normal;
flat out vec3 v_geometric_normal;
flat out uint v_material;
out vec2 v_uv;
void main() {
  v_world = a_position;
  v_normal = a_normal;
  v_geometric_normal = a_geometric_normal;
  v_material = a_material;
  v_uv = a_uv;
  gl_Position = u_matrix * vec4(a_position, 1.0);
}

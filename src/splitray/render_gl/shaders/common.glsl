// Shared declarations, prepended to every shader after the #version line.
struct MaterialGpu {
  vec4 diffuse_share;   // rgb diffuse, a = 1 - reflectivity - transparency (clamped)
  vec4 specular_shine;  // rgb specular, a = shininess
  vec4 flags;           // x = transparency, y = diffuse texture (-1: none)
  vec4 ambient;         // rgb ambient colour when a = 1, else the diffuse colour is used
};
layout(std430, binding = 0) readonly buffer Materials { MaterialGpu materials[]; };
const int kMaxLights = 4;

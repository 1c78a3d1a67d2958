#pragma once
// The local illumination model shared by the renderers: Blinn-Phong (ambient + diffuse +
// specular with shininess, as in the fragment shader of paper 002), point lights with 1/d^2
// falloff, directional lights, Snell refraction and Schlick's Fresnel term.
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

#include "splitray/core/ray.hpp"
#include "splitray/core/scene.hpp"

namespace splitray {

// What a light delivers at a point: the unit direction towards it, the distance along that
// direction (infinite for directional lights) and the radiance arriving.
struct LightSample {
  Vec3 to_light;
  float distance = kInfinity;
  Vec3 radiance;
};

inline LightSample sample_light(const Light& light, const Vec3& p) {
  LightSample s;
  if (light.kind == Light::Kind::directional) {
    s.to_light = normalize(-light.direction);
    s.radiance = light.color * light.intensity;  // intensity scales directional light too
    return s;
  }
  const Vec3 d = light.position - p;
  const float d2 = std::max(dot(d, d), 1e-12f);
  s.distance = std::sqrt(d2);
  s.to_light = d / s.distance;
  s.radiance = light.color * (light.falloff ? light.intensity / d2 : light.intensity);
  return s;
}

// Diffuse + specular of one light at a point with shading normal n (unit, facing the viewer),
// `to_eye` unit, `diffuse` the material's diffuse colour there (Material::diffuse_at).
// `diffuse_share` scales the diffuse term (1 - reflectivity - transparency).
inline Vec3 phong(const Material& m, const Vec3& diffuse, float diffuse_share, const Vec3& n,
                  const Vec3& to_eye, const LightSample& light) {
  const float n_dot_l = dot(n, light.to_light);
  if (n_dot_l <= 0) return Vec3{0};
  Vec3 c = diffuse * (diffuse_share * n_dot_l);
  if (m.specular != Vec3{0}) {
    const Vec3 h = normalize(light.to_light + to_eye);
    const float n_dot_h = std::max(dot(n, h), 0.0f);
    c += m.specular * std::pow(n_dot_h, m.shininess);
  }
  return c * light.radiance;
}

// The texture coordinates of a hit from its triangle's vertex coordinates (barycentrics u of
// vertex 1, v of vertex 2).
inline Vec2 hit_uv(const std::array<Vec2, 3>& uv, float u, float v) {
  const float w = 1 - u - v;
  return {uv[0].x * w + uv[1].x * u + uv[2].x * v, uv[0].y * w + uv[1].y * u + uv[2].y * v};
}

// The share of light the Phong diffuse term carries for a material.
inline float diffuse_share(const Material& m) {
  return std::max(0.0f, 1.0f - m.reflectivity - m.transparency);
}

// Snell's law: d unit incident direction, n unit normal on the incident side (dot(d, n) < 0),
// eta = n_incident / n_transmitted. Empty on total internal reflection.
inline std::optional<Vec3> refract(const Vec3& d, const Vec3& n, float eta) {
  const float cos_i = -dot(d, n);
  const float k = 1 - eta * eta * (1 - cos_i * cos_i);
  if (k < 0) return std::nullopt;
  return normalize(d * eta + n * (eta * cos_i - std::sqrt(k)));
}

// Schlick's approximation of the Fresnel reflectance between media n1 (incident) and n2;
// cos_i the incident cosine, cos_t the transmitted one (the larger angle's cosine is used).
inline float schlick(float n1, float n2, float cos_i, float cos_t) {
  const float r0 = (n1 - n2) / (n1 + n2);
  const float c = 1 - (n1 <= n2 ? cos_i : cos_t);
  return r0 * r0 + (1 - r0 * r0) * c * c * c * c * c;
}

}  // namespace splitray

#pragma once
// A reader of our own for the AFF scenes of BART, the benchmark for animated ray tracing
// (Lext, Assarsson & Möller 2001), which assimp cannot read. It knows: polygons (p), polygon
// patches (pp), meshes (m), animated triangles (tpa), cones (c) and spheres (s), tessellated;
// includes (i); materials (f, fm), views (v), lights (l), background (b), animation
// parameters (a); key-framed transforms (k: transl / rot / scale, Kochanek-Bartels splines)
// and transform blocks (x NAME { ... }, xs NAME { ... }). It keeps what a renderer needs: the
// view (v) moved along the key-framed path named "camera" when there is one (BART's
// convention: its translation is the eye, its rotation turns the view direction -z and the
// up vector +y), the lights (l, la: positions as given, colours, no fall-off, as NFF's),
// materials (f: colour x Kd, Ks, Shine, T, index of refraction; fm: ambient, diffuse,
// specular, Shine, T, index), background (b) and ambient light (am). Textures
// (tt, texturecoords) are not read. Every problem is an Error naming file and line.
#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "splitray/core/scene.hpp"
#include "splitray/core/triangle.hpp"

namespace splitray {

struct AffAnimation {
  double start = 0, end = 0;
  int frames = 0;  // 0 when the scene has no `a` line
};

class AffScene {
 public:
  ~AffScene();
  AffScene(AffScene&&) noexcept;
  AffScene& operator=(AffScene&&) noexcept;

  // Reads `path` and every file it includes (relative to the including file's folder).
  static AffScene load(const std::string& path);

  const AffAnimation& animation() const { return animation_; }
  std::size_t triangle_count() const;
  // The scene's triangles at time `t` (seconds): transforms and animated triangles evaluated.
  std::vector<Triangle> triangles_at(double t) const;
  // The camera at time `t`: the file's view, moved by its "camera" path; empty without a view.
  std::optional<Camera> camera_at(double t) const;
  // The scene at time `t` as one mesh (a triangle soup in triangles_at's order) with the
  // file's materials per triangle, its lights, background, ambient light and camera_at(t).
  Scene scene_at(double t) const;

  struct Data;

 private:
  AffScene();
  std::unique_ptr<Data> data_;
  AffAnimation animation_;
};

// AffScene::load(path).scene_at(its animation's start).
Scene load_aff_scene(const std::string& path);

}  // namespace splitray

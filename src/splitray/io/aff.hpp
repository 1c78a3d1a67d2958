#pragma once
// A reader of our own for the AFF scenes of BART, the benchmark for animated ray tracing
// (Lext, Assarsson & Möller 2001), which assimp cannot read. It knows: polygons (p), polygon
// patches (pp), meshes (m), animated triangles (tpa), cones (c) and spheres (s), tessellated;
// includes (i); materials (f, fm), views (v), lights (l), background (b), animation
// parameters (a); key-framed transforms (k: transl / rot / scale, Kochanek-Bartels splines)
// and transform blocks (x NAME { ... }, xs NAME { ... }). Materials, lights and views are
// parsed and checked but not kept. Every problem is an Error naming file and line.
#include <cstddef>
#include <memory>
#include <string>
#include <vector>

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

  struct Data;

 private:
  AffScene();
  std::unique_ptr<Data> data_;
  AffAnimation animation_;
};

}  // namespace splitray

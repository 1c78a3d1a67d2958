#pragma once
// `animate --render DIR`: the frames of an animation through the Whitted renderer (or, with
// --mode hybrid, paper 002's GPU + CPU renderer in a headless OpenGL context kept for all
// frames) as DIR/frame-NNNN.png. BART scenes keep their materials, lights and camera path; other
// sequences get a camera framed on the first frame and lights fitted to it once, so that the
// lighting does not jump between frames. Every rank of an mpirun job makes its own from the
// first frame, so that any rank renders any frame as one process would.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/core/image.hpp"
#include "splitray/core/scene.hpp"
#include "splitray/io/frames.hpp"

namespace splitray::app {

struct FrameImageOptions {
  std::string dir;  // empty: render nothing
  int width = 640, height = 480;
  BuildConfig build;  // threads; the builder is the structure's default (whatever animate times)
  std::string mode = "whitted";  // or "hybrid"
};

class FrameRenderer {
 public:
  // Fits the lights to `first` now (BART scenes keep theirs).
  FrameRenderer(const FrameSequence& sequence, const std::vector<Triangle>& first,
                FrameImageOptions options);

  bool enabled() const { return !options_.dir.empty(); }
  std::string path(std::size_t frame) const;  // DIR/frame-NNNN.png

  // Renders frame `frame` (its triangles) and writes it atomically.
  void render(std::size_t frame, const std::vector<Triangle>& triangles);

  // The scene of a frame: the first frame's with these triangles (valid until the next call).
  const Scene& scene(const std::vector<Triangle>& triangles);
  // The image of the scene last set by scene(), as frame `frame` (its camera), through
  // `accel` built over flatten(scene).triangles; null: the structure's default build.
  Image image(std::size_t frame, std::unique_ptr<Accel> accel, std::uint64_t& rays) const;

  FrameRenderer(FrameRenderer&&) noexcept;
  ~FrameRenderer();

 private:
  struct Hybrid;  // the OpenGL context and hybrid renderer, made at the first hybrid frame
  Image hybrid_image(std::size_t frame, std::unique_ptr<Accel> accel, std::uint64_t& rays) const;

  const FrameSequence& sequence_;
  FrameImageOptions options_;
  Scene scene_;
  std::vector<Triangle> triangles_;  // of the scene last set by scene()
  Camera fixed_camera_;
  mutable std::unique_ptr<Hybrid> hybrid_;
};

}  // namespace splitray::app

#pragma once
// The rays a frame of an animation costs a renderer (issue #20's frame time): a primary pass
// of W x H pixels from the frame's camera, then one shadow ray per hit towards the scene's
// light, both batched. The time of the two traces is what `animate` reports as trace ms.
#include <cstddef>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/core/camera.hpp"
#include "splitray/io/frames.hpp"

namespace splitray::app {

struct FramePassSetup {
  Camera fixed_camera;  // mesh sequences: framed on the first frame; BART: per-frame cameras
  Vec3 light;           // BART: the scene's first light; others: above, in front (see .cpp)
  int width = 1024, height = 768;
};

// For `sequence` whose first frame is `first`.
FramePassSetup frame_pass_setup(const FrameSequence& sequence, const std::vector<Triangle>& first,
                                int width, int height);

struct FramePassResult {
  double trace_ms = 0;  // primary + shadow traces
  std::size_t rays = 0;
  std::vector<Hit> hits;               // of the primary rays
  std::vector<std::uint8_t> shadowed;  // per primary ray (0 where it missed)
};

// Traces frame `frame` of the sequence through `accel` built over `triangles`.
FramePassResult trace_frame_pass(const FramePassSetup& setup, const FrameSequence& sequence,
                                 std::size_t frame, const Accel& accel,
                                 const std::vector<Triangle>& triangles);

}  // namespace splitray::app

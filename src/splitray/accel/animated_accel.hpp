#pragma once
// One interface for keeping a structure over the frames of an animation (issue #20): a
// strategy made by name, whose next_frame(triangles) returns the structure for that frame with
// what the update cost. The strategies users choose between:
//   kd-coherent    kd-tree rebuilt from the previous frame's (coherent_builder.hpp)
//   kd-rebuild     kd-tree built from scratch every frame (golden)
//   bvh-refit      BVH built on the first frame, refitted to every later one
//   bvh-rebuild    BVH built from scratch every frame (binned)
//   embree-refit   one Embree scene, vertices updated and the BVH refitted (Embree's recipe)
//   embree-low     the same scene rebuilt at Embree's low build quality every frame
//   embree-medium  ... at its medium quality
// Frame 0 is the initial build. Every frame must have the first frame's triangle count.
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/accel/kd/coherent_builder.hpp"
#include "splitray/accel/predict/split_predictor.hpp"

namespace splitray {

struct AnimationFrameStats {
  double update_ms = 0;  // build, refit or rebuild of this frame (wall time)
  // The finished structure's statistics: SAH cost (with the constants it names), nodes, ...
  AccelStats accel;
  std::optional<CoherentFrameStats> coherent;  // kd-coherent: reuse and the time's parts
};

class AnimatedAccel {
 public:
  virtual ~AnimatedAccel() = default;
  // The structure of the next frame, valid until the next call. Throws Error when the count
  // of `triangles` differs from the first frame's or the frame is empty.
  const Accel& next_frame(std::span<const Triangle> triangles, AnimationFrameStats& stats);
  const std::string& name() const { return name_; }
  std::size_t frame() const { return frame_; }  // frames done

 protected:
  explicit AnimatedAccel(std::string name) : name_(std::move(name)) {}
  virtual const Accel& update(std::span<const Triangle> triangles, AnimationFrameStats& stats) = 0;

 private:
  std::string name_;
  std::size_t frame_ = 0, triangles_ = 0;
};

// The strategies' names, in the order above.
std::vector<std::string> animation_strategy_names();

// Makes a strategy by name (Error listing the names on an unknown one). `config` sets threads
// and constants (its builder, when given, replaces the strategy's from-scratch builder: kd:
// golden only for kd-coherent; bvh: binned or sbvh); `predictor` steers kd-coherent.
std::unique_ptr<AnimatedAccel> make_animated_accel(const std::string& name,
                                                   const BuildConfig& config = {},
                                                   const PredictorConfig& predictor = {});

}  // namespace splitray

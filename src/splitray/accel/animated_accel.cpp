#include "splitray/accel/animated_accel.hpp"

#include "splitray/accel/embree/embree_accel.hpp"
#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"

namespace splitray {

namespace {

constexpr const char* kNames[] = {"kd-coherent",  "kd-rebuild", "bvh-refit",    "bvh-rebuild",
                                  "embree-refit", "embree-low", "embree-medium"};

class KdCoherent final : public AnimatedAccel {
 public:
  KdCoherent(const BuildConfig& config, const PredictorConfig& predictor)
      : AnimatedAccel("kd-coherent"), builder_(config, predictor) {}

 protected:
  const Accel& update(std::span<const Triangle> triangles, AnimationFrameStats& stats) override {
    CoherentFrameStats coherent;
    current_ = builder_.next_frame(triangles, coherent);
    stats.update_ms = coherent.total_ms;
    stats.coherent = coherent;
    return *current_;
  }

 private:
  KdCoherentBuilder builder_;
  std::unique_ptr<KdAccel> current_;
};

// A structure made by make_accel every frame, or made once and refitted.
class Rebuilt final : public AnimatedAccel {
 public:
  Rebuilt(std::string name, std::string accel, const BuildConfig& config, bool refit)
      : AnimatedAccel(std::move(name)), accel_(std::move(accel)), config_(config), refit_(refit) {}

 protected:
  const Accel& update(std::span<const Triangle> triangles, AnimationFrameStats& stats) override {
    const ThreadLimit limit(config_.threads);
    const Timer timer;
    if (!(refit_ && current_ && current_->refit(triangles)))
      current_ = make_accel(accel_, triangles, config_);
    stats.update_ms = timer.ms();
    return *current_;
  }

 private:
  std::string accel_;
  BuildConfig config_;
  bool refit_;
  std::unique_ptr<Accel> current_;
};

// One Embree scene whose vertices every frame updates and commits again.
class Embree final : public AnimatedAccel {
 public:
  Embree(std::string name, const BuildConfig& config)
      : AnimatedAccel(std::move(name)), config_(config) {}

 protected:
  const Accel& update(std::span<const Triangle> triangles, AnimationFrameStats& stats) override {
    const ThreadLimit limit(config_.threads);
    if (!scene_) {
      const Timer timer;
      scene_ = make_embree_scene(triangles, config_);
      stats.update_ms = timer.ms();
    } else {
      stats.update_ms = scene_->update(triangles);
    }
    return *scene_;
  }

 private:
  BuildConfig config_;
  std::unique_ptr<EmbreeScene> scene_;
};

}  // namespace

const Accel& AnimatedAccel::next_frame(std::span<const Triangle> triangles,
                                       AnimationFrameStats& stats) {
  if (triangles.empty())
    throw Error("animation " + name_, "frame " + std::to_string(frame_) + " has no triangles");
  if (frame_ > 0 && triangles.size() != triangles_)
    throw Error("animation " + name_,
                "frame " + std::to_string(frame_) + " has " + std::to_string(triangles.size()) +
                    " triangles, the first frame " + std::to_string(triangles_));
  stats = AnimationFrameStats{};
  const Accel& accel = update(triangles, stats);
  stats.accel = accel.stats();
  if (frame_ == 0) triangles_ = triangles.size();
  ++frame_;
  return accel;
}

std::vector<std::string> animation_strategy_names() {
  return {std::begin(kNames), std::end(kNames)};
}

std::unique_ptr<AnimatedAccel> make_animated_accel(const std::string& name,
                                                   const BuildConfig& config,
                                                   const PredictorConfig& predictor) {
  BuildConfig c = config;
  if (name == "kd-coherent") return std::make_unique<KdCoherent>(c, predictor);
  if (name == "kd-rebuild") {
    if (c.builder.empty()) c.builder = "golden";
    return std::make_unique<Rebuilt>(name, "kd", c, false);
  }
  if (name == "bvh-refit" || name == "bvh-rebuild")
    return std::make_unique<Rebuilt>(name, "bvh", c, name == "bvh-refit");
  if (name == "embree-refit" || name == "embree-low" || name == "embree-medium") {
    c.builder = name.substr(7);
    return std::make_unique<Embree>(name, c);
  }
  std::string names;
  for (const char* n : kNames) names += std::string(names.empty() ? "" : ", ") + n;
  throw Error("animation strategy " + name, "unknown (expected one of " + names + ")");
}

}  // namespace splitray

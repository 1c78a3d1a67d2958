#pragma once
// Animation frame sequences: each frame a triangle soup with the same triangles (count and
// order) as the first. FRAMES arguments may be
//   - files, one frame each (any mesh format load_mesh reads, .gz included);
//   - a glob ("frames/horse-*.obj.gz"), expanded and sorted;
//   - a printf pattern ("horse-%02d.obj.gz"), numbered from 0 (or 1 when 0 is absent) up to
//     the first missing number;
//   - a directory, all its files sorted by name;
//   - one MD2 file: its keyframes, each imported by assimp (AI_CONFIG_IMPORT_MD2_KEYFRAME);
//   - one BART scene (*.aff): its animation sampled at the frames of its `a` line.
#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "splitray/core/scene.hpp"
#include "splitray/core/triangle.hpp"

namespace splitray {

class AffScene;

// File names of the mesh-file arguments (globs, patterns and directories expanded). Throws
// Error naming the argument when it matches nothing.
std::vector<std::string> expand_frame_paths(const std::vector<std::string>& args);

class FrameSequence {
 public:
  // Throws Error naming the argument when it is not a readable sequence.
  explicit FrameSequence(const std::vector<std::string>& args);
  ~FrameSequence();
  FrameSequence(FrameSequence&&) noexcept;
  FrameSequence& operator=(FrameSequence&&) noexcept;

  std::size_t size() const { return labels_.size(); }
  const std::string& label(std::size_t frame) const { return labels_.at(frame); }
  // The triangles of one frame (no count check; see load_frames).
  std::vector<Triangle> load(std::size_t frame) const;
  // BART scenes: the camera of one frame (the file's view on its camera path) and the scene of
  // the first frame (materials per triangle, lights, background); empty for other sequences.
  std::optional<Camera> camera(std::size_t frame) const;
  std::optional<Scene> scene() const;

 private:
  enum class Kind { files, md2, aff };
  Kind kind_ = Kind::files;
  std::string source_;               // the MD2 or AFF file
  std::vector<std::string> labels_;  // file names, or "file#frame"
  std::unique_ptr<AffScene> aff_;
  double aff_start_ = 0, aff_end_ = 0;
  double aff_time(std::size_t frame) const;
};

// The first `max_frames` frames (0 = all), refusing a frame whose triangle count differs
// from the first frame's with an Error naming both frames.
std::vector<std::vector<Triangle>> load_frames(const FrameSequence& frames,
                                               std::size_t max_frames = 0);

}  // namespace splitray

#pragma once
// `mpirun -np N splitray animate FRAMES --render DIR` (and, in one process, --render-only or
// --resume): the frames handed out by rank 0 as a work queue of runs of consecutive frames.
// Each rank rebuilds its kd-tree frame after frame steered by its own split predictor (paper
// 000) and keeps the predictor while its frames follow each other; the first frame of a run
// that does not follow the rank's last frame starts a fresh predictor and is built as frame 0
// is, by golden's full search. Rank 0 writes every frame atomically as it arrives. The images
// equal one process's: every structure returns the same hits (the tie rule of Hit).
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "frame_renderer.hpp"
#include "splitray/accel/predict/split_predictor.hpp"
#include "splitray/dist/work_queue.hpp"

namespace splitray::app {

struct AnimationRenderOptions {
  FrameImageOptions image;
  BuildConfig build;                     // the predicted kd build (golden's search)
  PredictorConfig predictor;             // kind none: golden from scratch every frame
  std::size_t max_frames = 0;            // 0 = all
  std::size_t run_length = 0;            // consecutive frames per hand-out; 0 = auto_run_length
  bool resume = false;                   // render only frames whose output is not a complete PNG
  std::function<void(double)> progress;  // rank 0
};

struct RenderedFrame {
  std::size_t frame = 0;
  int rank = 0;
  bool predicted = false;  // continued the rank's predictor from the previous frame
  double load_ms = 0, build_ms = 0, render_ms = 0;
  std::uint64_t rays = 0;
};

struct AnimationRender {
  std::size_t frames = 0;               // of the sequence (after max_frames)
  std::vector<RenderedFrame> rendered;  // rank 0: in the order they arrived
  std::vector<std::size_t> kept;        // resume: outputs found complete, left alone
  std::vector<dist::RankStats> ranks;
  std::size_t run_length = 0;
  double wall_ms = 0;  // the queue, from the first hand-out to the last frame written
};

// Every rank calls it with the same arguments. Rank 0 throws a JobError naming the frame and
// the rank when a frame fails; the frames written before stay complete.
AnimationRender render_animation(const FrameSequence& sequence,
                                 const AnimationRenderOptions& options);

// Runs of about a quarter of each rank's share (at least 1, at most 16): long enough that
// predictions pay, short enough that the last runs balance the ranks.
std::size_t auto_run_length(std::size_t frames, int ranks);

// Whether `path` is a PNG of width x height that decodes completely (read, not assumed from
// its name): what --resume keeps.
bool complete_png(const std::string& path, int width, int height);

}  // namespace splitray::app

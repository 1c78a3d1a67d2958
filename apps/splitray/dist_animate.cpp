#include "dist_animate.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cstring>
#include <optional>
#include <string_view>
#include <utility>

#include "splitray/accel/kd/coherent_builder.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/image.hpp"
#include "splitray/core/timer.hpp"
#include "splitray/dist/world.hpp"
#include "splitray/io/read_file.hpp"
#include "splitray/io/texture_io.hpp"

namespace splitray::app {

namespace {

// What a rank sends before a frame's PNG.
struct FrameHeader {
  std::uint64_t frame = 0, rays = 0;
  double load_ms = 0, build_ms = 0, render_ms = 0;
  std::uint8_t predicted = 0;
};

std::string to_bytes(const std::vector<std::uint64_t>& values) {
  std::string bytes(values.size() * sizeof(std::uint64_t), '\0');
  std::memcpy(bytes.data(), values.data(), bytes.size());
  return bytes;
}

std::vector<std::uint64_t> from_bytes(const std::string& bytes) {
  std::vector<std::uint64_t> values(bytes.size() / sizeof(std::uint64_t));
  std::memcpy(values.data(), bytes.data(), values.size() * sizeof(std::uint64_t));
  return values;
}

// Width and height from a PNG's IHDR chunk ({0, 0} when it is no PNG).
std::pair<int, int> png_size(std::string_view png) {
  constexpr std::string_view kSignature("\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR", 16);
  if (png.size() < 24 || png.substr(0, 16) != kSignature) return {0, 0};
  const auto be32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    for (std::size_t i = 0; i < 4; ++i) v = v << 8 | static_cast<unsigned char>(png[at + i]);
    return static_cast<int>(std::min<std::uint32_t>(v, 1u << 30));
  };
  return {be32(16), be32(20)};
}

}  // namespace

std::size_t auto_run_length(std::size_t frames, int ranks) {
  const std::size_t quarter = (frames + 4 * static_cast<std::size_t>(ranks) - 1) /
                              (4 * static_cast<std::size_t>(std::max(ranks, 1)));
  return std::clamp<std::size_t>(quarter, 1, 16);
}

bool complete_png(const std::string& path, int width, int height) {
  try {
    const Bytes bytes = read_previous_output(path, std::size_t{1} << 30);  // may be redone
    const auto image = decode_texture(bytes, path);
    return image->width == width && image->height == height;
  } catch (const std::exception&) {
    return false;  // missing, unreadable or not a whole image: rendered again
  }
}

AnimationRender render_animation(const FrameSequence& sequence,
                                 const AnimationRenderOptions& options) {
  const dist::World& world = dist::world();
  const std::size_t count =
      options.max_frames ? std::min(options.max_frames, sequence.size()) : sequence.size();
  std::optional<FrameRenderer> renderer;
  std::size_t triangles = 0;
  dist::all_or_none([&] {
    const std::vector<Triangle> first = sequence.load(0);
    if (first.empty()) throw Error(sequence.label(0), "the first frame has no triangles");
    triangles = first.size();
    renderer.emplace(sequence, first, options.image);
  });

  AnimationRender out;
  out.frames = count;
  // The frames to render, chosen by rank 0 (the one that writes), known to all.
  std::string todo_bytes;
  if (world.rank == 0) {
    std::vector<std::uint64_t> todo;
    for (std::size_t f = 0; f < count; ++f) {
      if (options.resume &&
          complete_png(renderer->path(f), options.image.width, options.image.height))
        out.kept.push_back(f);
      else
        todo.push_back(f);
    }
    todo_bytes = to_bytes(todo);
  }
  dist::broadcast(todo_bytes);
  const std::vector<std::uint64_t> todo = from_bytes(todo_bytes);
  out.run_length =
      options.run_length ? options.run_length : auto_run_length(todo.size(), world.size);

  dist::QueueOptions queue;
  queue.units = todo.size();
  queue.run_length = out.run_length;
  queue.name = [&](std::size_t unit) {
    return fmt::format("frame {} ({})", todo[unit], sequence.label(todo[unit]));
  };

  BuildConfig build = options.build;
  build.builder = "golden";  // the coherent rebuild's from-scratch builder
  KdCoherentBuilder coherent(build, options.predictor);
  std::optional<std::size_t> last;  // this rank's last frame built, if it succeeded
  const auto work = [&](std::size_t unit) {
    FrameHeader header;
    header.frame = todo[unit];
    const std::size_t frame = todo[unit];
    const bool follows = last && *last + 1 == frame;
    last.reset();
    if (!follows) coherent.reset();
    header.predicted = follows;
    Timer timer;
    const std::vector<Triangle> tris = sequence.load(frame);
    if (tris.size() != triangles)
      throw Error(sequence.label(frame),
                  fmt::format("has {} triangles, the first frame {}: the frames of an animation "
                              "move the same triangles",
                              tris.size(), triangles));
    header.load_ms = timer.ms();
    timer.reset();
    const FlatScene flat = flatten(renderer->scene(tris));
    CoherentFrameStats stats;
    std::unique_ptr<Accel> accel = coherent.next_frame(flat.triangles, stats);
    header.build_ms = timer.ms();
    timer.reset();
    const Image image = renderer->image(frame, std::move(accel), header.rays);
    header.render_ms = timer.ms();
    last = frame;
    std::string bytes(sizeof header, '\0');
    std::memcpy(bytes.data(), &header, sizeof header);
    // Encoded here, on the rank that rendered it: rank 0 only writes the bytes (encoding every
    // frame there was a third of the frame time at 1024 x 768, serial, and PNGs are smaller
    // to send than pixels).
    return bytes + encode_png(image, queue.name(unit));
  };
  const auto collect = [&](std::size_t unit, int rank, std::string&& bytes) {
    FrameHeader header;
    if (bytes.size() < sizeof header) throw Error("result of " + queue.name(unit), "too short");
    std::memcpy(&header, bytes.data(), sizeof header);
    const std::string_view png = std::string_view(bytes).substr(sizeof header);
    if (header.frame != todo[unit] ||
        png_size(png) != std::pair{options.image.width, options.image.height})
      throw Error("result of " + queue.name(unit), "is not the frame asked for");
    write_file_atomically(renderer->path(todo[unit]), std::string(png));
    out.rendered.push_back({todo[unit], rank, header.predicted != 0, header.load_ms,
                            header.build_ms, header.render_ms, header.rays});
    if (options.progress)
      options.progress(static_cast<double>(out.rendered.size()) / static_cast<double>(todo.size()));
  };
  const Timer timer;
  out.ranks = dist::run_queue(queue, work, collect);
  out.wall_ms = timer.ms();
  return out;
}

}  // namespace splitray::app

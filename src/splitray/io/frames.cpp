#include "splitray/io/frames.hpp"

#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <glob.h>

#include <algorithm>
#include <assimp/Importer.hpp>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <regex>

#include "splitray/core/coordinates.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/io/aff.hpp"
#include "splitray/io/format_checks.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/io/read_file.hpp"

namespace splitray {

namespace fs = std::filesystem;

namespace {

constexpr std::size_t kMaxFrames = 100000;

bool is_glob(const std::string& s) { return s.find_first_of("*?[") != std::string::npos; }

// "%d", "%02d", "%4d": one integer conversion, the rest literal ("%%" allowed).
bool is_printf_pattern(const std::string& s) {
  static const std::regex conversion("%0?[0-9]*d");
  return std::regex_search(s, conversion);
}

std::string format_pattern(const std::string& pattern, std::size_t i) {
  std::string out;
  std::size_t k = 0;
  bool used = false;
  while (k < pattern.size()) {
    if (pattern[k] != '%') {
      out += pattern[k++];
      continue;
    }
    if (k + 1 < pattern.size() && pattern[k + 1] == '%') {
      out += '%';
      k += 2;
      continue;
    }
    std::size_t e = k + 1;
    while (e < pattern.size() && std::isdigit(static_cast<unsigned char>(pattern[e]))) ++e;
    if (e >= pattern.size() || pattern[e] != 'd' || used)
      throw Error(pattern, "a frame pattern takes exactly one integer conversion such as %02d");
    const std::string spec = pattern.substr(k, e - k + 1);
    char buffer[64];
    std::snprintf(buffer, sizeof buffer, spec.c_str(), static_cast<int>(i));
    out += buffer;
    used = true;
    k = e + 1;
  }
  return out;
}

std::vector<std::string> expand_one(const std::string& arg) {
  std::vector<std::string> out;
  if (fs::is_directory(arg)) {
    for (const auto& entry : fs::directory_iterator(arg))
      if (entry.is_regular_file()) out.push_back(entry.path().string());
    std::sort(out.begin(), out.end());
    if (out.empty()) throw Error(arg, "the frame folder holds no files");
  } else if (fs::exists(arg)) {
    out.push_back(arg);
  } else if (is_printf_pattern(arg)) {
    std::size_t i = fs::exists(format_pattern(arg, 0)) ? 0 : 1;
    for (; out.size() < kMaxFrames; ++i) {
      std::string name = format_pattern(arg, i);
      if (!fs::exists(name)) break;
      out.push_back(std::move(name));
    }
    if (out.empty()) throw Error(arg, "no file matches the frame pattern (tried numbers 0 and 1)");
  } else if (is_glob(arg)) {
    glob_t g{};
    const int rc = ::glob(arg.c_str(), 0, nullptr, &g);
    if (rc == 0)
      for (std::size_t k = 0; k < g.gl_pathc; ++k) out.emplace_back(g.gl_pathv[k]);
    globfree(&g);
    if (out.empty()) throw Error(arg, "no file matches the pattern");
    std::sort(out.begin(), out.end());
  } else {
    throw Error(arg, "no such file, folder or frame pattern");
  }
  return out;
}

// Keyframes of an MD2 file (the int32 at byte 40 of its header), once the whole file checks.
int md2_frame_count(const std::string& path) {
  const Bytes bytes = read_file(path);
  check_md2(bytes, path);
  std::int32_t frames;
  std::memcpy(&frames, bytes.data() + 40, 4);
  return frames;
}

std::vector<Triangle> load_md2_frame(const std::string& path, int frame) {
  // The bytes checked are the bytes assimp reads (the file may change between frames).
  const Bytes bytes = read_file(path);
  check_md2(bytes, path);
  Assimp::Importer importer;
  importer.SetPropertyInteger(AI_CONFIG_IMPORT_MD2_KEYFRAME, frame);
  const aiScene* scene = importer.ReadFileFromMemory(bytes.data(), bytes.size(),
                                                     aiProcess_ValidateDataStructure, "md2");
  if (!scene || scene->mNumMeshes == 0)
    throw Error(path + " frame " + std::to_string(frame),
                std::string("assimp cannot read it: ") + importer.GetErrorString());
  // MD2 vertices come unindexed, three per triangle, in the same order in every frame.
  const aiMatrix4x4 m = scene->mRootNode ? scene->mRootNode->mTransformation : aiMatrix4x4();
  std::vector<Triangle> out;
  for (unsigned k = 0; k < scene->mNumMeshes; ++k) {
    const aiMesh& mesh = *scene->mMeshes[k];
    for (unsigned f = 0; f < mesh.mNumFaces; ++f) {
      const aiFace& face = mesh.mFaces[f];
      if (face.mNumIndices != 3) continue;
      Vec3 v[3];
      for (int c = 0; c < 3; ++c) {
        if (face.mIndices[c] >= mesh.mNumVertices)
          throw Error(path + " frame " + std::to_string(frame),
                      "face " + std::to_string(f) + " has vertex index " +
                          std::to_string(face.mIndices[c]) + " beyond its " +
                          std::to_string(mesh.mNumVertices) + " vertices");
        const aiVector3D p = m * mesh.mVertices[face.mIndices[c]];
        v[c] = {p.x, p.y, p.z};
      }
      out.push_back({v[0], v[1], v[2]});
    }
  }
  return out;
}

}  // namespace

std::vector<std::string> expand_frame_paths(const std::vector<std::string>& args) {
  std::vector<std::string> out;
  for (const std::string& arg : args) {
    std::vector<std::string> files = expand_one(arg);
    out.insert(out.end(), files.begin(), files.end());
  }
  return out;
}

FrameSequence::FrameSequence(const std::vector<std::string>& args) {
  if (args.empty()) throw Error("FRAMES", "no frames given");
  const std::string ext =
      args.size() == 1 && fs::is_regular_file(args[0]) ? inner_extension(args[0]) : "";
  if (ext == "md2") {
    kind_ = Kind::md2;
    source_ = args[0];
    const int n = md2_frame_count(source_);
    for (int i = 0; i < n; ++i) labels_.push_back(source_ + "#" + std::to_string(i));
  } else if (ext == "aff") {
    kind_ = Kind::aff;
    source_ = args[0];
    aff_ = std::make_unique<AffScene>(AffScene::load(source_));
    const AffAnimation& a = aff_->animation();
    if (a.frames < 1) throw Error(source_, "the scene has no animation parameters (an `a` line)");
    aff_start_ = a.start;
    aff_end_ = a.end;
    for (int i = 0; i < a.frames; ++i) labels_.push_back(source_ + "#" + std::to_string(i));
  } else {
    labels_ = expand_frame_paths(args);
  }
}

FrameSequence::~FrameSequence() = default;
FrameSequence::FrameSequence(FrameSequence&&) noexcept = default;
FrameSequence& FrameSequence::operator=(FrameSequence&&) noexcept = default;

double FrameSequence::aff_time(std::size_t frame) const {
  const double n = static_cast<double>(size());
  return n > 1 ? aff_start_ + (aff_end_ - aff_start_) * static_cast<double>(frame) / (n - 1)
               : aff_start_;
}

std::optional<Camera> FrameSequence::camera(std::size_t frame) const {
  if (kind_ != Kind::aff || frame >= size()) return std::nullopt;
  return aff_->camera_at(aff_time(frame));
}

std::optional<Scene> FrameSequence::scene() const {
  if (kind_ != Kind::aff) return std::nullopt;
  return aff_->scene_at(aff_time(0));
}

std::vector<Triangle> FrameSequence::load(std::size_t frame) const {
  if (frame >= size()) throw Error(source_, "frame " + std::to_string(frame) + " does not exist");
  std::vector<Triangle> triangles;
  switch (kind_) {
    case Kind::md2:
      triangles = load_md2_frame(source_, static_cast<int>(frame));
      break;
    case Kind::aff:
      triangles = aff_->triangles_at(aff_time(frame));
      break;
    case Kind::files:
      return load_mesh(labels_[frame]).triangles();  // load_mesh validates the mesh
  }
  // MD2 keyframes (scaled by the file's per-frame factors) and AFF frames (moved by its
  // animated transforms) get the checks of a loaded mesh.
  if (triangles.empty()) throw Error(label(frame), "the frame has no triangles");
  check_triangles(triangles, label(frame));
  return triangles;
}

std::vector<std::vector<Triangle>> load_frames(const FrameSequence& frames,
                                               std::size_t max_frames) {
  const std::size_t n = max_frames == 0 ? frames.size() : std::min(max_frames, frames.size());
  std::vector<std::vector<Triangle>> out;
  out.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    out.push_back(frames.load(i));
    if (out.back().size() != out.front().size())
      throw Error(frames.label(i),
                  "frame " + std::to_string(i) + " has " + std::to_string(out.back().size()) +
                      " triangles but frame 0 (" + frames.label(0) + ") has " +
                      std::to_string(out.front().size()) +
                      "; every frame of an animation must keep the triangle count");
  }
  return out;
}

}  // namespace splitray

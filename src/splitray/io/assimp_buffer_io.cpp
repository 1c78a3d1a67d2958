#include "splitray/io/assimp_buffer_io.hpp"

#include <algorithm>
#include <assimp/IOStream.hpp>
#include <cstring>
#include <filesystem>

#include "splitray/io/read_file.hpp"

namespace splitray {
namespace {

class BufferStream : public Assimp::IOStream {
 public:
  explicit BufferStream(std::span<const unsigned char> bytes) : bytes_(bytes) {}

  size_t Read(void* out, size_t size, size_t count) override {
    if (size == 0 || count == 0 || pos_ >= bytes_.size()) return 0;
    const size_t n = std::min(count, (bytes_.size() - pos_) / size);
    std::memcpy(out, bytes_.data() + pos_, n * size);
    pos_ += n * size;
    return n;
  }
  size_t Write(const void*, size_t, size_t) override { return 0; }
  aiReturn Seek(size_t offset, aiOrigin origin) override {
    size_t target = 0;
    switch (origin) {
      case aiOrigin_SET:
        target = offset;
        break;
      case aiOrigin_CUR:
        if (offset > bytes_.size() - pos_) return AI_FAILURE;
        target = pos_ + offset;
        break;
      case aiOrigin_END:
        if (offset > bytes_.size()) return AI_FAILURE;
        target = bytes_.size() - offset;
        break;
      default:
        return AI_FAILURE;
    }
    if (target > bytes_.size()) return AI_FAILURE;
    pos_ = target;
    return AI_SUCCESS;
  }
  size_t Tell() const override { return pos_; }
  size_t FileSize() const override { return bytes_.size(); }
  void Flush() override {}

 private:
  std::span<const unsigned char> bytes_;
  size_t pos_ = 0;
};

bool is_regular_file(const char* file) {
  std::error_code ec;
  return std::filesystem::is_regular_file(file, ec);
}

}  // namespace

BufferIOSystem::BufferIOSystem(std::string name, std::span<const unsigned char> bytes,
                               std::string root)
    : name_(std::move(name)), bytes_(bytes), root_(std::move(root)) {}

bool BufferIOSystem::inside_root(const char* file) const {
  if (inside_folder(root_, file)) return true;
  if (refused_.empty()) refused_ = file;
  return false;
}

bool BufferIOSystem::Exists(const char* file) const {
  return name_ == file || (inside_root(file) && is_regular_file(file));
}

Assimp::IOStream* BufferIOSystem::Open(const char* file, const char* mode) {
  if (name_ == file) return new BufferStream(bytes_);
  if (std::strchr(mode, 'w') || !inside_root(file) || !is_regular_file(file)) return nullptr;
  return DefaultIOSystem::Open(file, mode);
}

void BufferIOSystem::Close(Assimp::IOStream* stream) { delete stream; }

}  // namespace splitray

#pragma once
// An assimp IOSystem that serves one file from memory (a gunzipped or pre-checked buffer)
// under its real name, so that assimp resolves the files it references (OBJ mtllib, glTF
// buffers, COLLADA images) beside it on disk. Only regular files are opened from disk: a
// hostile reference to a FIFO or device cannot hang or flood the import.
#include <assimp/DefaultIOSystem.h>

#include <span>
#include <string>

namespace splitray {

class BufferIOSystem : public Assimp::DefaultIOSystem {
 public:
  // `bytes` must outlive the importer that owns this IOSystem.
  BufferIOSystem(std::string name, std::span<const unsigned char> bytes)
      : name_(std::move(name)), bytes_(bytes) {}

  bool Exists(const char* file) const override;
  Assimp::IOStream* Open(const char* file, const char* mode = "rb") override;
  void Close(Assimp::IOStream* stream) override;

 private:
  std::string name_;
  std::span<const unsigned char> bytes_;
};

}  // namespace splitray

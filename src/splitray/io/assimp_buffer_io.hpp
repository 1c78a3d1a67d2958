#pragma once
// An assimp IOSystem that serves one file from memory (a gunzipped or pre-checked buffer)
// under its real name, so that assimp resolves the files it references (OBJ mtllib, glTF
// buffers, COLLADA images) beside it on disk. Only regular files are opened from disk: a
// hostile reference to a FIFO or device cannot hang or flood the import. Only files inside
// `root` (after resolving `..` and links) are opened: a glTF buffer URI ../../etc/passwd is
// refused and remembered, so that the loader can name it. The same rule (`inside_folder`,
// io/read_file.hpp) confines the textures that materials name (io/materials.cpp).
#include <assimp/DefaultIOSystem.h>

#include <filesystem>
#include <span>
#include <string>

namespace splitray {

class BufferIOSystem : public Assimp::DefaultIOSystem {
 public:
  // `bytes` must outlive the importer that owns this IOSystem.
  BufferIOSystem(std::string name, std::span<const unsigned char> bytes, std::string root);

  bool Exists(const char* file) const override;
  Assimp::IOStream* Open(const char* file, const char* mode = "rb") override;
  void Close(Assimp::IOStream* stream) override;

  // The first file asked for outside the root, or "" when none was.
  const std::string& refused() const { return refused_; }

 private:
  std::string name_;
  std::span<const unsigned char> bytes_;
  std::string root_;
  mutable std::string refused_;
  bool inside_root(const char* file) const;
};

}  // namespace splitray

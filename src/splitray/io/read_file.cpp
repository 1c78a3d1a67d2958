#include "splitray/io/read_file.hpp"

#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "splitray/core/errors.hpp"

namespace splitray {
namespace {

std::string size_text(std::size_t bytes) {
  if (bytes >= (std::size_t{1} << 30) && bytes % (std::size_t{1} << 30) == 0)
    return std::to_string(bytes >> 30) + " GiB";
  return std::to_string(bytes) + " bytes";
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

Bytes read_file(const std::string& path, std::size_t max_bytes) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (status.type() == fs::file_type::not_found) throw Error(path, "no such file");
  if (ec) throw Error(path, "cannot access the file: " + ec.message());
  if (status.type() == fs::file_type::directory) throw Error(path, "is a directory, not a file");
  if (status.type() != fs::file_type::regular) throw Error(path, "is not a regular file");
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec) throw Error(path, "cannot read the file size: " + ec.message());
  if (size == 0) throw Error(path, "the file is empty");
  if (size > max_bytes)
    throw Error(path, "the file is larger than the limit of " + size_text(max_bytes));

  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, std::string("cannot open the file: ") + std::strerror(errno));
  Bytes bytes(static_cast<std::size_t>(size));
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(size));
  if (static_cast<std::uintmax_t>(in.gcount()) != size)
    throw Error(path, "the file could not be read completely (it changed while reading?)");
  return bytes;
}

Bytes gunzip(std::span<const unsigned char> in, const std::string& where, std::size_t max_bytes) {
  if (in.size() < 2 || in[0] != 0x1f || in[1] != 0x8b)
    throw Error(where, "not gzip data (the gzip signature 1f 8b is missing)");

  z_stream zs{};
  if (inflateInit2(&zs, 16 + MAX_WBITS) != Z_OK) throw Error(where, "cannot initialise zlib");
  struct Guard {
    z_stream* zs;
    ~Guard() { inflateEnd(zs); }
  } guard{&zs};

  // zlib counts in 32-bit units: feed and drain in chunks of at most 1 GiB.
  constexpr std::size_t kChunk = std::size_t{1} << 30;
  Bytes out(std::min(max_bytes + 1, std::max<std::size_t>(std::size_t{1} << 16, 4 * in.size())));
  std::size_t consumed = 0, produced = 0;
  for (;;) {
    if (produced == out.size()) {
      if (out.size() > max_bytes)
        throw Error(where, "decompresses to more than the limit of " + size_text(max_bytes) +
                               " (a corrupt or malicious .gz?)");
      out.resize(std::min(max_bytes + 1, out.size() * 2));
    }
    const std::size_t in_chunk = std::min(kChunk, in.size() - consumed);
    const std::size_t out_chunk = std::min(kChunk, out.size() - produced);
    zs.next_in = const_cast<unsigned char*>(in.data() + consumed);
    zs.avail_in = static_cast<uInt>(in_chunk);
    zs.next_out = out.data() + produced;
    zs.avail_out = static_cast<uInt>(out_chunk);
    const int rc = inflate(&zs, Z_NO_FLUSH);
    consumed += in_chunk - zs.avail_in;
    produced += out_chunk - zs.avail_out;
    if (rc == Z_STREAM_END) {
      // Another gzip member may follow (concatenated .gz files); zero padding is harmless.
      const auto rest = in.subspan(consumed);
      if (rest.size() >= 2 && rest[0] == 0x1f && rest[1] == 0x8b) {
        inflateReset(&zs);
        continue;
      }
      if (std::any_of(rest.begin(), rest.end(), [](unsigned char b) { return b != 0; }))
        throw Error(where, "corrupt gzip data: unexpected bytes after the end of the gzip stream");
      break;
    }
    if (rc == Z_DATA_ERROR || rc == Z_NEED_DICT || rc == Z_STREAM_ERROR)
      throw Error(where, std::string("corrupt gzip data: ") + (zs.msg ? zs.msg : "invalid stream"));
    if (rc == Z_MEM_ERROR) throw Error(where, "out of memory while decompressing");
    if (produced > max_bytes)
      throw Error(where, "decompresses to more than the limit of " + size_text(max_bytes) +
                             " (a corrupt or malicious .gz?)");
    // Z_OK or Z_BUF_ERROR: progress is possible only with more input or more output room.
    if (consumed == in.size() && produced < out.size())
      throw Error(where, "truncated gzip data (the compressed stream ends early)");
  }
  out.resize(produced);
  if (out.empty()) throw Error(where, "the decompressed file is empty");
  return out;
}

bool has_gz_suffix(const std::string& path) {
  return path.size() > 3 && lower(path.substr(path.size() - 3)) == ".gz";
}

Bytes read_maybe_gzipped(const std::string& path, std::size_t max_bytes) {
  Bytes bytes = read_file(path, max_bytes);
  return has_gz_suffix(path) ? gunzip(bytes, path, max_bytes) : bytes;
}

std::string inner_extension(const std::string& path) {
  const std::string name = std::filesystem::path(path).filename().string();
  const std::string inner = has_gz_suffix(name) ? name.substr(0, name.size() - 3) : name;
  const auto dot = inner.rfind('.');
  return dot == std::string::npos || dot == 0 ? std::string{} : lower(inner.substr(dot + 1));
}

}  // namespace splitray

#include "splitray/io/read_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>

#include "splitray/core/errors.hpp"
#include "splitray/core/output_file.hpp"

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

// An open regular file, closed by the destructor.
struct RegularFile {
  int fd = -1;
  std::uintmax_t size = 0;
  ~RegularFile() {
    if (fd >= 0) ::close(fd);
  }
};

void open_regular(const std::string& path, RegularFile& file, bool note = true) {
  // O_NONBLOCK: opening a FIFO must not wait for a writer; fstat of the open file then
  // decides, so that a name swapped between a check and the open cannot slip through.
  file.fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (file.fd < 0) {
    const int error = errno;
    if (error == ENOENT) throw Error(path, "no such file");
    throw Error(path, std::string("cannot open the file: ") + std::strerror(error));
  }
  struct stat st {};
  if (::fstat(file.fd, &st) != 0)
    throw Error(path, std::string("cannot access the file: ") + std::strerror(errno));
  if (S_ISDIR(st.st_mode)) throw Error(path, "is a directory, not a file");
  if (!S_ISREG(st.st_mode))
    throw Error(path, std::string("is not a regular file (it is ") +
                          (S_ISFIFO(st.st_mode)   ? "a FIFO"
                           : S_ISSOCK(st.st_mode) ? "a socket"
                                                  : "a device") +
                          "); splitray reads only regular files");
  if (note) note_input_file(path, st.st_dev, st.st_ino);
  file.size = static_cast<std::uintmax_t>(st.st_size);
  if (file.size == 0) throw Error(path, "the file is empty");
}

// Up to bytes.size() bytes from the start of the file; how many it read.
std::size_t read_into(const std::string& path, const RegularFile& file, Bytes& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::read(file.fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw Error(path, std::string("read error: ") + std::strerror(errno));
    if (n == 0) break;
    done += static_cast<std::size_t>(n);
  }
  return done;
}

Bytes read_whole(const std::string& path, std::size_t max_bytes, bool note) {
  RegularFile file;
  open_regular(path, file, note);
  if (file.size > max_bytes)
    throw Error(path, "the file is larger than the limit of " + size_text(max_bytes));
  Bytes bytes(static_cast<std::size_t>(file.size));
  if (read_into(path, file, bytes) != file.size)
    throw Error(path, "the file could not be read completely (it changed while reading?)");
  return bytes;
}

}  // namespace

Bytes read_file(const std::string& path, std::size_t max_bytes) {
  return read_whole(path, max_bytes, true);
}

Bytes read_previous_output(const std::string& path, std::size_t max_bytes) {
  return read_whole(path, max_bytes, false);
}

Bytes read_file_head(const std::string& path, std::size_t max_bytes) {
  RegularFile file;
  open_regular(path, file);
  Bytes bytes(static_cast<std::size_t>(std::min<std::uintmax_t>(file.size, max_bytes)));
  bytes.resize(read_into(path, file, bytes));
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

bool inside_folder(const std::filesystem::path& folder, const std::string& file) {
  std::error_code folder_error, file_error;
  const std::filesystem::path root =
      std::filesystem::weakly_canonical(std::filesystem::absolute(folder), folder_error);
  const std::filesystem::path resolved =
      std::filesystem::weakly_canonical(std::filesystem::absolute(file), file_error);
  if (folder_error || file_error || root.empty()) return false;
  const auto [end, ignored] =
      std::mismatch(root.begin(), root.end(), resolved.begin(), resolved.end());
  return end == root.end();
}

}  // namespace splitray

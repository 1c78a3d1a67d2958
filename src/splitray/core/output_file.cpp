#include "splitray/core/output_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <utility>
#include <vector>

#include "splitray/core/errors.hpp"

namespace splitray {
namespace {

struct Input {
  dev_t device;
  ino_t inode;
  std::string path;
};

// The process's noted inputs and output options; readers may run on several threads.
struct Registry {
  std::mutex mutex;
  std::vector<Input> inputs;
  std::map<std::string, std::string> options;  // output path -> option
};

Registry& registry() {
  static Registry r;
  return r;
}

std::string where(const std::string& path) {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  const auto it = r.options.find(path);
  return it == r.options.end() ? path : it->second + " " + path;
}

// What a non-regular file is, for the error.
const char* kind_of(mode_t mode) {
  if (S_ISLNK(mode)) return "a symbolic link";
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "a device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

}  // namespace

void note_input_file(const std::string& path, dev_t device, ino_t inode) {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  for (const Input& input : r.inputs)
    if (input.device == device && input.inode == inode) return;
  r.inputs.push_back({device, inode, path});
}

void note_input_file(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0) note_input_file(path, st.st_dev, st.st_ino);
}

void note_output_option(const std::string& path, const std::string& option) {
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  r.options[path] = option;
}

void check_output_file(const std::string& path) {
  if (path.empty()) throw Error(where(path), "the output file name is empty");
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) return;  // a new file: its folder is checked when it is created
    throw Error(where(path), std::string("cannot check the output file: ") + std::strerror(errno));
  }
  if (!S_ISREG(st.st_mode))
    throw Error(where(path), std::string("the output exists and is ") + kind_of(st.st_mode) +
                                 "; splitray replaces only regular files (remove it or choose "
                                 "another name)");
  Registry& r = registry();
  const std::lock_guard lock(r.mutex);
  for (const Input& input : r.inputs)
    if (input.device == st.st_dev && input.inode == st.st_ino) {
      const auto it = r.options.find(path);
      throw Error(it == r.options.end() ? path : it->second + " " + path,
                  "the output is the same file as the input " + input.path +
                      "; refusing to overwrite an input");
    }
}

void check_noted_outputs() {
  std::vector<std::string> paths;
  {
    Registry& r = registry();
    const std::lock_guard lock(r.mutex);
    for (const auto& entry : r.options) paths.push_back(entry.first);
  }
  for (const std::string& path : paths) check_output_file(path);
}

TemporaryFile::TemporaryFile(std::string path, const std::string& suffix) : path_(std::move(path)) {
  check_output_file(path_);
  static std::atomic<unsigned> counter{0};
  tmp_ = path_ + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++) + suffix;
  fd_ = ::open(tmp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
  if (fd_ < 0)
    throw Error(where(path_), std::string("cannot write the file (does the folder exist and is "
                                          "it writable?): ") +
                                  std::strerror(errno));
}

TemporaryFile::~TemporaryFile() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_) ::unlink(tmp_.c_str());
}

void TemporaryFile::write(const std::string& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0)
      throw Error(where(path_), std::string("cannot write the file: ") +
                                    (n < 0 ? std::strerror(errno) : "no progress"));
    done += static_cast<std::size_t>(n);
  }
}

void TemporaryFile::commit() {
  const int fd = std::exchange(fd_, -1);
  if (fd >= 0 && ::close(fd) != 0)
    throw Error(where(path_), std::string("cannot write the file: ") + std::strerror(errno));
  check_output_file(path_);  // nothing replaced it with a link or FIFO meanwhile
  if (::rename(tmp_.c_str(), path_.c_str()) != 0)
    throw Error(where(path_),
                std::string("cannot write the file (rename failed): ") + std::strerror(errno));
  committed_ = true;
}

void write_file_atomically(const std::string& path, const std::string& bytes) {
  TemporaryFile file(path);
  file.write(bytes);
  file.commit();
}

}  // namespace splitray

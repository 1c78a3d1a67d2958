#pragma once
// Outputs never destroy data. Every file splitray writes goes to a temporary file beside it
// that is renamed into place, and only over nothing or over a regular file that is none of
// this process's inputs: never over an input (compared by device and inode, so hard links and
// other spellings of the path are caught), a symbolic link, a FIFO, a device or a folder.
// Inputs are noted by the readers (io/read_file) and by the CLI while it parses its options,
// so that an output equal to an input is refused before any work.
#include <sys/types.h>

#include <string>

namespace splitray {

// Remembers an input file; nothing happens when `path` does not exist (the reader reports it).
void note_input_file(const std::string& path);
// The same, for a file already opened and fstat'ed.
void note_input_file(const std::string& path, dev_t device, ino_t inode);
// Remembers which option an output path came from, so that errors name it ("-o x.png: ...").
void note_output_option(const std::string& path, const std::string& option);

// Throws Error naming the option (when noted) and the path unless `path` may be replaced:
// it does not exist, or it is a regular file (not a link to one) and not a noted input.
void check_output_file(const std::string& path);
// check_output_file for every path given to note_output_option.
void check_noted_outputs();

// A temporary file beside `path` (same folder, so that the rename is atomic), created
// exclusively (never through an existing name or link); removed by the destructor unless
// commit() renamed it into place. `suffix` ends the temporary name (programs that pick the
// format from the name).
class TemporaryFile {
 public:
  explicit TemporaryFile(std::string path, const std::string& suffix = "");
  ~TemporaryFile();
  TemporaryFile(const TemporaryFile&) = delete;
  TemporaryFile& operator=(const TemporaryFile&) = delete;

  const std::string& name() const { return tmp_; }
  // Writes all of `bytes` to the temporary file (once, right after construction).
  void write(const std::string& bytes);
  // check_output_file(path) again, then renames the temporary file to `path`.
  void commit();

 private:
  std::string path_, tmp_;
  int fd_ = -1;
  bool committed_ = false;
};

// Writes bytes to `path` atomically through a TemporaryFile.
void write_file_atomically(const std::string& path, const std::string& bytes);

}  // namespace splitray

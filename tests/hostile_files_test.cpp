// The hostile-input table of issue #23 (tests/hostile_files/table.txt): every row through the
// splitray program under a 2 GiB address-space limit and a timeout. A row passes when the run
// exits with code 1 (not a signal, not a timeout), stderr names the file (or option) and
// contains the expected text, no file appeared in the folder and none changed. The commands
// run in the folder, beside the special files (FIFOs, folders, links) of the "@" lines.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <zlib.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "test_data.hpp"

namespace fs = std::filesystem;

namespace {

using splitray::test::quote;
using splitray::test::read_text;

const std::string kBinary = SPLITRAY_BINARY_DIR "/apps/splitray/splitray";
const fs::path kTable = fs::path(SPLITRAY_SOURCE_DIR) / "tests" / "hostile_files";

struct Row {
  int line = 0;
  std::string file, defect, command, expected;
  bool option = false;  // the message names an option rather than the file
};

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(' '), e = s.find_last_not_of(' ');
  return b == std::string::npos ? "" : s.substr(b, e - b + 1);
}

// "@fifo NAME", "@folder NAME", "@symlink NAME TARGET", "@hardlink NAME TARGET".
struct Special {
  std::string kind, name, target;
};

std::vector<Row> read_table(std::vector<Special>& specials) {
  std::ifstream in(kTable / "table.txt");
  std::vector<Row> rows;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (trim(line).empty() || trim(line)[0] == '#') continue;
    if (line[0] == '@') {
      std::istringstream words(line);
      Special special;
      words >> special.kind >> special.name >> special.target;
      specials.push_back(special);
      continue;
    }
    std::vector<std::string> cells;
    for (std::size_t at = 0;;) {
      const std::size_t bar = line.find(" | ", at);
      cells.push_back(trim(line.substr(at, bar == std::string::npos ? bar : bar - at)));
      if (bar == std::string::npos) break;
      at = bar + 3;
    }
    EXPECT_EQ(cells.size(), 4u) << "table.txt line " << number << ": expected 4 cells";
    if (cells.size() != 4) continue;
    Row row{number, cells[0], cells[1], cells[2], cells[3]};
    row.option = row.defect.rfind("option:", 0) == 0;
    rows.push_back(row);
  }
  return rows;
}

// 1 GiB of zeros as gzip (about 1 MiB).
void write_gzip_bomb(const fs::path& path) {
  gzFile out = gzopen(path.c_str(), "wb9");
  ASSERT_NE(out, nullptr);
  const std::vector<char> zeros(1 << 20, 0);
  for (int i = 0; i < 1024; ++i)
    ASSERT_EQ(gzwrite(out, zeros.data(), zeros.size()), static_cast<int>(zeros.size()));
  ASSERT_EQ(gzclose(out), Z_OK);
}

void make_special(const fs::path& dir, const Special& s) {
  const fs::path path = dir / s.name;
  if (s.kind == "@fifo") {
    ASSERT_EQ(mkfifo(path.c_str(), 0600), 0) << s.name;
  } else if (s.kind == "@folder") {
    fs::create_directory(path);
  } else if (s.kind == "@symlink") {
    fs::create_symlink(s.target, path);
  } else if (s.kind == "@hardlink") {
    fs::create_hard_link(dir / s.target, path);
  } else {
    FAIL() << "table.txt: unknown special file " << s.kind;
  }
}

// Name -> hash of every entry of `dir`: a regular file's content, a link's target (a link
// replaced by a copy of its target is a change), other kinds by type only.
std::map<std::string, std::size_t> snapshot(const fs::path& dir) {
  std::map<std::string, std::size_t> files;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string text = entry.is_symlink() ? "link " + fs::read_symlink(entry).string()
                             : entry.is_regular_file()
                                 ? read_text(entry.path())
                                 : std::to_string(static_cast<int>(entry.status().type()));
    files[entry.path().filename().string()] = std::hash<std::string>{}(text);
  }
  return files;
}

std::string replace_all(std::string text, const std::string& from, const std::string& to) {
  for (std::size_t at = 0; (at = text.find(from, at)) != std::string::npos; at += to.size())
    text.replace(at, from.size(), to);
  return text;
}

TEST(HostileFiles, EveryRowFailsCleanlyNamesItsFileAndTouchesNothing) {
  ASSERT_TRUE(fs::exists(kBinary)) << kBinary;
  std::vector<Special> specials;
  const std::vector<Row> rows = read_table(specials);
  ASSERT_GE(rows.size(), 10u);
  const fs::path dir = splitray::test::temp_dir("hostile_files");
  for (const auto& entry : fs::directory_iterator(kTable))
    fs::copy_file(entry.path(), dir / entry.path().filename());
  write_gzip_bomb(dir / "bomb.obj.gz");
  for (const Special& special : specials) make_special(dir, special);
  const auto before = snapshot(dir);
  for (const Row& row : rows) {
    const std::string where =
        "table.txt line " + std::to_string(row.line) + " (" + row.defect + ")";
    const std::string in = (dir / row.file).string();
    const std::string args = replace_all(replace_all(row.command, "{in}", quote(in)), "{out}",
                                         quote((dir / "out").string()));
    const fs::path err = dir.parent_path() / "hostile_files_stderr.txt";
#if defined(__SANITIZE_ADDRESS__)
    const std::string limit;  // AddressSanitizer reserves terabytes of address space
#else
    const std::string limit = "prlimit --as=2147483648 ";
#endif
    const std::string command = "cd " + quote(dir.string()) + " && " + limit + "timeout 60 " +
                                quote(kBinary) + " " + args + " > /dev/null 2> " +
                                quote(err.string()) + " < /dev/null";
    const int raw = std::system(command.c_str());
    const std::string message = read_text(err);
    fs::remove(err);
    ASSERT_NE(raw, -1) << where;
    ASSERT_TRUE(WIFEXITED(raw)) << where << ": killed by a signal\n" << message;
    EXPECT_NE(WEXITSTATUS(raw), 124) << where << ": timed out\n" << message;
    EXPECT_EQ(WEXITSTATUS(raw), 1) << where << ": splitray " << args << "\n" << message;
    EXPECT_NE(message.find(row.expected), std::string::npos)
        << where << ": expected '" << row.expected << "' in\n"
        << message;
    if (!row.option) {
      EXPECT_NE(message.find(row.file), std::string::npos)
          << where << ": the message should name " << row.file << "\n"
          << message;
    }
    EXPECT_EQ(snapshot(dir), before) << where << ": a file appeared or changed";
  }
}

}  // namespace

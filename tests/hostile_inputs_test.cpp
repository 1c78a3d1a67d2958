// The hostile-input table (issue #23): every row of tests/data/hostile/cases.tsv runs one
// splitray command in a fresh copy of tests/data/hostile, under a memory limit (prlimit --as)
// and a timeout, and must end with exit code 1 (no signal, no hang), an error containing the
// row's text, no file left behind (no output, no temporary) and every file of the folder
// unchanged. The table's header says how to add a row.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "test_data.hpp"

namespace fs = std::filesystem;

namespace {

const std::string kBinary = SPLITRAY_BINARY_DIR "/apps/splitray/splitray";
const fs::path kHostile = splitray::test::source_dir() / "tests" / "data" / "hostile";
constexpr int kTimeoutSeconds = 30;
// Address space for one command: far above what these small files need (the vendored
// models, TBB and Embree's arenas included), far below what a bomb would take.
constexpr const char* kMemoryLimit = "2147483648";  // 2 GiB, in bytes (prlimit has no suffixes)

struct Row {
  int line = 0;
  std::string args, expected, what;
};

// "@fifo NAME", "@folder NAME", "@symlink NAME TARGET", "@hardlink NAME TARGET": special
// files the test makes in each copy (git cannot hold them).
struct Special {
  std::string kind, name, target;
};

struct Table {
  std::vector<Special> specials;
  std::vector<Row> rows;
};

std::vector<std::string> split_tabs(const std::string& line) {
  std::vector<std::string> fields;
  std::istringstream in(line);
  for (std::string field; std::getline(in, field, '\t');) fields.push_back(field);
  return fields;
}

Table read_table() {
  Table table;
  std::ifstream in(kHostile / "cases.tsv");
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.empty() || line[0] == '#') continue;
    if (line[0] == '@') {
      std::istringstream words(line);
      Special s;
      words >> s.kind >> s.name >> s.target;
      table.specials.push_back(s);
      continue;
    }
    const auto fields = split_tabs(line);
    EXPECT_EQ(fields.size(), 3u) << "cases.tsv line " << number
                                 << ": want ARGS<TAB>EXPECTED<TAB>WHAT";
    if (fields.size() == 3) table.rows.push_back({number, fields[0], fields[1], fields[2]});
  }
  return table;
}

// Every entry of the folder (recursively, links not followed): its type and, for regular
// files, its content.
std::map<std::string, std::string> snapshot(const fs::path& dir) {
  std::map<std::string, std::string> entries;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    const std::string name = fs::relative(entry.path(), dir).string();
    const fs::file_status status = entry.symlink_status();
    std::string value = std::to_string(static_cast<int>(status.type())) + "\n";
    if (status.type() == fs::file_type::regular) value += splitray::test::read_text(entry);
    if (status.type() == fs::file_type::symlink) value += fs::read_symlink(entry).string();
    entries[name] = value;
  }
  return entries;
}

void make_specials(const fs::path& dir, const std::vector<Special>& specials) {
  for (const Special& s : specials) {
    const fs::path path = dir / s.name;
    if (s.kind == "@fifo")
      ASSERT_EQ(::mkfifo(path.c_str(), 0644), 0) << s.name;
    else if (s.kind == "@folder")
      fs::create_directories(path);
    else if (s.kind == "@symlink")
      fs::create_symlink(s.target, path);
    else if (s.kind == "@hardlink")
      fs::create_hard_link(dir / s.target, path);
    else
      FAIL() << "cases.tsv: unknown special file kind " << s.kind;
  }
}

struct Outcome {
  int status = -1;  // exit code, 128 + signal when killed
  std::string err;
};

Outcome run_in(const fs::path& dir, const std::string& args, const fs::path& logs) {
#if defined(__SANITIZE_ADDRESS__)
  const std::string limit;  // AddressSanitizer reserves terabytes of address space
#else
  const std::string limit = std::string("prlimit --as=") + kMemoryLimit + " -- ";
#endif
  const fs::path err = logs / "stderr.txt";
  const std::string command = "cd " + splitray::test::quote(dir.string()) + " && timeout -s KILL " +
                              std::to_string(kTimeoutSeconds) + " " + limit +
                              splitray::test::quote(kBinary) + " " + args + " > /dev/null 2> " +
                              splitray::test::quote(err.string()) + " < /dev/null";
  const int raw = std::system(command.c_str());
  Outcome outcome;
  if (raw != -1 && WIFEXITED(raw)) outcome.status = WEXITSTATUS(raw);
  if (raw != -1 && WIFSIGNALED(raw)) outcome.status = 128 + WTERMSIG(raw);
  outcome.err = splitray::test::read_text(err);
  return outcome;
}

TEST(HostileInputs, EveryRowFailsCleanly) {
  const Table table = read_table();
  ASSERT_FALSE(table.rows.empty()) << "no rows in " << (kHostile / "cases.tsv");
  const fs::path root = splitray::test::temp_dir("hostile_inputs");
  for (const Row& row : table.rows) {
    SCOPED_TRACE("cases.tsv line " + std::to_string(row.line) + ": splitray " + row.args + "  (" +
                 row.what + ")");
    const fs::path dir = root / ("row" + std::to_string(row.line));
    fs::copy(kHostile, dir, fs::copy_options::recursive);
    fs::remove(dir / "cases.tsv");
    make_specials(dir, table.specials);
    const auto before = snapshot(dir);
    const Outcome outcome = run_in(dir, row.args, root);
    EXPECT_EQ(outcome.status, 1) << (outcome.status == 128 + 9 ? "killed: a hang or a timeout? "
                                                               : "")
                                 << outcome.err;
    EXPECT_EQ(outcome.err.rfind("splitray: ", 0), 0u) << outcome.err;
    EXPECT_NE(outcome.err.find(row.expected), std::string::npos)
        << "want '" << row.expected << "' in: " << outcome.err;
    const auto after = snapshot(dir);
    for (const auto& [name, value] : after) {
      const auto it = before.find(name);
      if (it == before.end())
        ADD_FAILURE() << "left behind: " << name;
      else if (it->second != value)
        ADD_FAILURE() << "changed: " << name;
    }
    for (const auto& entry : before)
      if (!after.count(entry.first)) ADD_FAILURE() << "removed: " << entry.first;
    if (!::testing::Test::HasFailure()) fs::remove_all(dir);
  }
}

}  // namespace

#include "splitray/core/memory_budget.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>

#include "splitray/core/errors.hpp"

namespace splitray {

namespace {

constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();

// What the machine gives this process: physical memory, the cgroup v2 limit, ulimit -v.
std::size_t machine_memory() {
  std::size_t bytes = kNone;
  const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGE_SIZE);
  if (pages > 0 && page > 0)
    bytes = static_cast<std::size_t>(pages) * static_cast<std::size_t>(page);
  std::ifstream cgroup("/sys/fs/cgroup/memory.max");
  std::string text;
  if (cgroup >> text && text != "max") {
    std::size_t limit = 0;
    const auto [ptr, ec] = std::from_chars(text.data(), text.data() + text.size(), limit);
    if (ec == std::errc{} && limit > 0) bytes = std::min(bytes, limit);
  }
  rlimit as{};
  if (getrlimit(RLIMIT_AS, &as) == 0 && as.rlim_cur != RLIM_INFINITY)
    bytes = std::min(bytes, static_cast<std::size_t>(as.rlim_cur));
  return bytes == kNone ? std::size_t{1} << 32 : bytes;
}

std::atomic<std::size_t>& budget() {
  static std::atomic<std::size_t> value{std::max<std::size_t>(machine_memory() / 2, 64u << 20)};
  return value;
}

}  // namespace

std::size_t memory_budget() { return budget().load(std::memory_order_relaxed); }

void set_memory_budget(std::size_t bytes) { budget().store(bytes, std::memory_order_relaxed); }

std::size_t parse_memory_size(const std::string& text, const std::string& where) {
  double value = 0;
  const char* first = text.data();
  const char* last = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(first, last, value);
  double scale = 1;
  const std::string suffix(ptr, last);
  if (suffix.size() == 1 || (suffix.size() == 2 && (suffix[1] == 'B' || suffix[1] == 'b'))) {
    const char s = static_cast<char>(std::toupper(static_cast<unsigned char>(suffix[0])));
    scale = s == 'K' ? 0x1p10 : s == 'M' ? 0x1p20 : s == 'G' ? 0x1p30 : s == 'T' ? 0x1p40 : 0;
  } else if (!suffix.empty()) {
    scale = 0;
  }
  const double bytes = value * scale;
  if (ec != std::errc{} || scale == 0 || !(bytes >= 1) || bytes > 0x1p62)
    throw Error(where, "'" + text + "' is not a memory size (expected e.g. 512M, 2G or 1.5G)");
  return static_cast<std::size_t>(bytes);
}

std::string memory_size_text(double bytes) {
  const char* units[] = {"bytes", "KiB", "MiB", "GiB", "TiB"};
  int u = 0;
  while (bytes >= 1024 && u < 4) bytes /= 1024, ++u;
  char text[32];
  std::snprintf(text, sizeof text, u == 0 ? "%.0f %s" : "%.1f %s", bytes, units[u]);
  return text;
}

void check_memory(std::size_t count, std::size_t size, const std::string& what,
                  const std::string& where) {
  const std::size_t limit = memory_budget();
  if (size == 0 || count <= limit / size) return;
  throw Error(where, what + " needs " +
                         memory_size_text(static_cast<double>(count) * static_cast<double>(size)) +
                         ", more than the memory budget of " +
                         memory_size_text(static_cast<double>(limit)) +
                         " (raise it with --max-memory SIZE)");
}

}  // namespace splitray

#pragma once
// The memory one splitray process lets its inputs claim (issue #23): a declared count in a
// file, a decompressed stream or a requested ray count beyond it is an Error naming the file or
// option before anything is allocated, never an "out of memory" (or the OOM killer) later.
// The default fits the machine: half of the smallest of physical memory, the cgroup's limit
// and the address-space limit (ulimit -v); `--max-memory SIZE` sets it on every command.
#include <cstddef>
#include <string>

namespace splitray {

std::size_t memory_budget();
void set_memory_budget(std::size_t bytes);

// "512M", "2G", "1.5g", "4096" (bytes; suffixes K, M, G, T are powers of 1024). Throws
// Error(where, ...) on anything else or on zero.
std::size_t parse_memory_size(const std::string& text, const std::string& where);
// "1.5 GiB".
std::string memory_size_text(double bytes);

// Throws Error(where, "<what> needs <size>, more than the memory budget ...") when `bytes`
// (count * size, overflow-safe) exceed the budget.
void check_memory(std::size_t count, std::size_t size, const std::string& what,
                  const std::string& where);

}  // namespace splitray

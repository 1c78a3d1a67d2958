// libFuzzer target: gunzip (every *.gz input goes through it) in memory, with a 16 MiB output
// budget so that bombs must stop at the budget (an allocation past it is a finding), and
// through a file (read_maybe_gzipped) as the loaders call it.
#include "fuzz_input.hpp"
#include "splitray/io/read_file.hpp"

namespace {
constexpr std::size_t kBudget = std::size_t{16} << 20;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const splitray::Bytes out = splitray::gunzip({data, size}, "input.gz", kBudget);
    if (out.size() > kBudget) splitray::fuzz::finding("gunzip returned more than its budget");
  } catch (const splitray::Error&) {
  }
  const std::string path = splitray::fuzz::write_input(data, size, "input.obj.gz");
  try {
    const splitray::Bytes out = splitray::read_maybe_gzipped(path, kBudget);
    if (out.size() > kBudget)
      splitray::fuzz::finding("read_maybe_gzipped returned more than its budget");
  } catch (const splitray::Error&) {
  }
  return 0;
}

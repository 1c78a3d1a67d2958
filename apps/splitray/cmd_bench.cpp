// splitray bench ...: the benchmarks of bench/ (also the program splitray_bench).
#include "bench_commands.hpp"
#include "commands.hpp"

namespace splitray::app {

void add_bench_command(CLI::App& app) {
  CLI::App* bench = app.add_subcommand(
      "bench", "Benchmarks, measured against Embree, nanoflann and FLANN in the same run");
  bench->require_subcommand(1);
  bench::add_bench_subcommands(*bench);
}

}  // namespace splitray::app

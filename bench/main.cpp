// splitray_bench: the benchmark programs of splitray (same code as `splitray bench`).
#include <fmt/core.h>

#include <exception>

#include "bench_commands.hpp"
#include "splitray/core/errors.hpp"

int main(int argc, char** argv) {
  CLI::App app{
      "splitray_bench: benchmarks measured against Embree, nanoflann and FLANN in the same run",
      "splitray_bench"};
  app.require_subcommand(1);
  splitray::bench::add_bench_subcommands(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const std::exception& e) {
    fmt::print(stderr, "splitray_bench: {}\n", e.what());
    return 1;
  }
  return 0;
}

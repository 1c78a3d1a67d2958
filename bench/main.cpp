// splitray_bench: the benchmark programs of splitray (same code as `splitray bench`).
#include <fmt/core.h>

#include <exception>

#include "build_trace.hpp"
#include "splitray/core/errors.hpp"

int main(int argc, char** argv) {
  CLI::App app{"splitray_bench: benchmarks measured against Embree in the same run",
               "splitray_bench"};
  app.require_subcommand(1);
  splitray::bench::BuildTraceOptions options;
  CLI::App* build_trace = app.add_subcommand(
      "build-trace",
      "Build time, SAH cost and Mrays/s of every kd builder and Embree on real meshes");
  splitray::bench::add_build_trace_options(*build_trace, options);
  build_trace->callback([&options] { splitray::bench::build_trace_command(options); });
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

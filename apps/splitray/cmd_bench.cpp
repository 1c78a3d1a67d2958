// splitray bench build-trace: the benchmark of bench/ (also the program splitray_bench).
#include <memory>

#include "build_trace.hpp"
#include "commands.hpp"

namespace splitray::app {

void add_bench_command(CLI::App& app) {
  CLI::App* bench =
      app.add_subcommand("bench", "Benchmarks, measured against Embree in the same run");
  bench->require_subcommand(1);
  auto options = std::make_shared<bench::BuildTraceOptions>();
  CLI::App* build_trace = bench->add_subcommand(
      "build-trace",
      "Build time, SAH cost, cost evaluations and Mrays/s (primary, diffuse) of every kd builder "
      "and Embree low/medium/high on every real mesh; JSON and Markdown reports");
  bench::add_build_trace_options(*build_trace, *options);
  build_trace->callback([options] { bench::build_trace_command(*options); });
}

}  // namespace splitray::app

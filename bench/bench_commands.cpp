#include "bench_commands.hpp"

#include <memory>

#include "build_trace.hpp"
#include "knn_bench.hpp"

namespace splitray::bench {

void add_bench_subcommands(CLI::App& bench) {
  auto build_trace_options = std::make_shared<BuildTraceOptions>();
  CLI::App* build_trace = bench.add_subcommand(
      "build-trace",
      "Build time, SAH cost, cost evaluations and Mrays/s (primary, diffuse) of every kd builder "
      "and Embree low/medium/high on every real mesh; JSON and Markdown reports");
  add_build_trace_options(*build_trace, *build_trace_options);
  build_trace->callback([build_trace_options] { build_trace_command(*build_trace_options); });

  auto knn_options = std::make_shared<KnnBenchOptions>();
  CLI::App* knn = bench.add_subcommand(
      "knn",
      "Build time and queries/s of our point kd-trees (k-nearest for k = 1, 8, 16 and radius "
      "search) against nanoflann and FLANN on real meshes sampled to 1M points");
  add_knn_bench_options(*knn, *knn_options);
  knn->callback([knn_options] {
    // Non-zero when structures disagreed on the answers: the report says which.
    if (const int code = run_knn_bench(*knn_options); code != 0) throw CLI::RuntimeError(code);
  });
}

}  // namespace splitray::bench

#pragma once
// Every benchmark as a subcommand of a CLI11 app: shared by `splitray bench` and the standalone
// program `splitray_bench`, so both run the same code with the same options.
#include <CLI/CLI.hpp>

namespace splitray::bench {

// Adds build-trace, knn, ... to `bench` (which should require one subcommand).
void add_bench_subcommands(CLI::App& bench);

}  // namespace splitray::bench

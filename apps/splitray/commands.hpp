#pragma once
// Each subcommand of `splitray` lives in its own file (cmd_NAME.cpp) and adds itself to the
// app here; main.cpp calls every add_*_command and turns Errors into messages + exit codes.
#include <CLI/CLI.hpp>

namespace splitray::app {

void add_render_command(CLI::App& app);
void add_build_command(CLI::App& app);
void add_trace_command(CLI::App& app);
void add_bench_command(CLI::App& app);
void add_knn_command(CLI::App& app);
void add_animate_command(CLI::App& app);
void add_view_command(CLI::App& app);
void add_train_command(CLI::App& app);
void add_completion_command(CLI::App& app);  // hidden: the bash completion script

}  // namespace splitray::app

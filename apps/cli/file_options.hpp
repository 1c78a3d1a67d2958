#pragma once
// Options that name files, for the rule of core/output_file.hpp: an output never replaces an
// input, a link, a FIFO, a device or a folder. Inputs are noted as CLI11 runs the options'
// callbacks; check_outputs_before_running makes the program check every output after parsing
// and before the command runs, so that `-o` equal to the input fails before any work.
#include <CLI/CLI.hpp>

namespace splitray::cli {

// Marks `option` as naming input files; returns it for chaining.
CLI::Option* input_files(CLI::Option* option);
// Marks `option` as naming an output file (errors then name the option); returns it.
CLI::Option* output_file(CLI::Option* option);
// Checks every marked output once `app` has parsed its arguments.
void check_outputs_before_running(CLI::App& app);

}  // namespace splitray::cli

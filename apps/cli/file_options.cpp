#include "file_options.hpp"

#include "splitray/core/output_file.hpp"

namespace splitray::cli {

CLI::Option* input_files(CLI::Option* option) {
  return option->each([](const std::string& path) { note_input_file(path); });
}

CLI::Option* output_file(CLI::Option* option) {
  const std::string label = option->get_name();  // the long name ("--output", not "-o")
  return option->each([label](const std::string& path) { note_output_option(path, label); });
}

void check_outputs_before_running(CLI::App& app) {
  // Runs after every option callback (inputs noted) and before any subcommand's callback.
  app.parse_complete_callback([] { check_noted_outputs(); });
}

}  // namespace splitray::cli

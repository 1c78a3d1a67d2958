#include "json_output.hpp"

#include <fmt/core.h>

#include <iostream>

#include "file_options.hpp"
#include "splitray/core/output_file.hpp"

namespace splitray::cli {

void add_json_options(CLI::App& command, JsonOutput& output, const std::string& keys) {
  command.add_flag("--json", output.print,
                   "Print the result as one JSON object on stdout" +
                       (keys.empty() ? std::string() : ": " + keys));
  output_file(command.add_option("--json-out", output.file,
                                 "Write the same JSON object to this file (atomically)"));
}

void emit_json(const JsonOutput& output, const nlohmann::ordered_json& object) {
  const std::string text = object.dump(2) + "\n";
  if (!output.file.empty()) write_file_atomically(output.file, text);
  if (output.print) std::cout << text << std::flush;
}

void warn(const std::string& text) {
  std::fflush(stdout);
  fmt::print(stderr, "splitray: warning: {}\n", text);
}

}  // namespace splitray::cli

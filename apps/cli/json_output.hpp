#pragma once
// The one JSON rule of every command, `bench ...` included: --json prints the command's result
// as one JSON object on stdout (and nothing else there), --json-out FILE writes the same
// object to FILE (atomically); both may be given. Also the warnings every command prints.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <string>

namespace splitray::cli {

struct JsonOutput {
  bool print = false;  // --json
  std::string file;    // --json-out FILE
  bool wanted() const { return print || !file.empty(); }
};

// Adds --json and --json-out to `command`; `keys` (optional) lists the object's keys in the
// help.
void add_json_options(CLI::App& command, JsonOutput& output, const std::string& keys = "");

// Prints `object` (2-space indented) on stdout when --json, writes it to --json-out's file.
void emit_json(const JsonOutput& output, const nlohmann::ordered_json& object);

// "splitray: warning: <text>" on stderr.
void warn(const std::string& text);

}  // namespace splitray::cli

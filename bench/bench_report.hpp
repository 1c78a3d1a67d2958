#pragma once
// The Markdown tables of a build-trace report (for people; the JSON is for machines).
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "json_output.hpp"

namespace splitray::bench {

std::string markdown_report(const nlohmann::ordered_json& report);

// The median of `values` (the mean of the middle two for an even count; 0 when empty): what
// every benchmark reports of its repeated runs.
double median(std::vector<double> values);

// Every benchmark's outputs by the one rule (cli/json_output.hpp): --json prints the report on
// stdout (and nothing else goes there), --json-out writes it, --markdown FILE writes the tables,
// which go to stdout when neither --markdown nor --json is given.
void emit_report(const cli::JsonOutput& json, const std::string& markdown_path,
                 const nlohmann::ordered_json& report, const std::string& markdown);

// Error(path, ...) for an output whose folder does not exist, before a long run.
void check_output_folders(const std::vector<std::string>& paths);

// The report as a JSON file for a plotting script: --json-out's file, or a temporary copy
// that `remove_temporary` deletes.
struct ReportFile {
  std::string path;
  bool temporary = false;
  ReportFile(const cli::JsonOutput& json, const nlohmann::ordered_json& report,
             const std::string& name);
  ~ReportFile();
};

}  // namespace splitray::bench

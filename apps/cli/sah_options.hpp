#pragma once
// --kt / --ki, the same in every command that builds: unset = each structure's own default
// (BuildConfig::sah), so the help names the per-structure defaults.
#include <CLI/CLI.hpp>
#include <optional>
#include <string>

namespace splitray::cli {

void add_sah_options(CLI::App& command, std::optional<float>& traversal_cost,
                     std::optional<float>& intersection_cost, const std::string& group = "");

}  // namespace splitray::cli

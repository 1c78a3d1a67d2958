#pragma once
// The Markdown tables of a build-trace report (for people; the JSON is for machines).
#include <nlohmann/json.hpp>

#include <string>

namespace splitray::bench {

std::string markdown_report(const nlohmann::ordered_json& report);

}  // namespace splitray::bench

#include "machine.hpp"

#include <embree3/rtcore_config.h>

#include <chrono>
#include <ctime>
#include <fstream>
#include <string>

#include "splitray/core/parallel.hpp"

namespace splitray::bench {

namespace {

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("model name", 0) != 0) continue;
    const auto colon = line.find(':');
    if (colon != std::string::npos) return line.substr(line.find_first_not_of(' ', colon + 1));
  }
  return "unknown";
}

std::string utc_now() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

}  // namespace

double load_average() {
  std::ifstream in("/proc/loadavg");
  double load = -1;
  return in >> load ? load : -1;
}

nlohmann::ordered_json machine_json(int threads) {
  return {{"cpu", cpu_model()},
          {"hardware_threads", hardware_threads()},
          {"threads", threads > 0 ? threads : hardware_threads()},
          {"compiler", __VERSION__},
          {"embree", RTC_VERSION_STRING},
          {"date_utc", utc_now()},
          {"load_average_start", load_average()}};
}

}  // namespace splitray::bench

#pragma once
// What a benchmark ran on, for its report: CPU, cores, threads, compiler, Embree, date, load.
#include <nlohmann/json.hpp>

namespace splitray::bench {

nlohmann::ordered_json machine_json(int threads);

// The 1-minute load average (/proc/loadavg), -1 if unknown: other work on the machine slows
// every measurement, so reports say how busy it was.
double load_average();

}  // namespace splitray::bench

#include "trace_measure.hpp"

#include <vector>

#include "bench_report.hpp"
#include "splitray/core/timer.hpp"

namespace splitray::bench {

using Json = nlohmann::ordered_json;

Json throughput(std::size_t count, int runs, const std::function<void()>& pass) {
  pass();
  std::vector<double> ms;
  for (int r = 0; r < runs; ++r) {
    Timer timer;
    pass();
    ms.push_back(timer.ms());
  }
  const double m = median(ms);
  return Json{{"mrays_per_s", m > 0 ? static_cast<double>(count) / (m * 1000.0) : 0.0},
              {"ms", m},
              {"ms_runs", ms}};
}

Checksum checksum(std::span<const Hit> hits) {
  Checksum c;
  for (const Hit& h : hits) {
    if (!h.found()) continue;
    ++c.hits;
    c.id_checksum += static_cast<std::uint64_t>(h.prim) + 1;
  }
  return c;
}

std::size_t differing(std::span<const Hit> a, std::span<const Hit> b) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) n += a[i].prim != b[i].prim;
  return n;
}

Json camera_json(const Camera& c, const std::string& view) {
  return Json{{"view", view},
              {"eye", {c.eye.x, c.eye.y, c.eye.z}},
              {"target", {c.target.x, c.target.y, c.target.z}},
              {"vfov_degrees", c.vfov_degrees}};
}

}  // namespace splitray::bench

#include "loss_report.hpp"

#include <fmt/core.h>

#include <algorithm>
#include <cmath>

#include "splitray/core/image.hpp"

namespace splitray::train {

void write_loss_csv(const std::string& path, const std::vector<EpochStats>& epochs) {
  std::string csv = "epoch,loss,tree_loss,bound_loss,mean_relative_cost,seconds\n";
  for (const EpochStats& e : epochs)
    csv += fmt::format("{},{:.8g},{:.8g},{:.8g},{:.8g},{:.2f}\n", e.epoch, e.loss, e.tree, e.bound,
                       e.cost, e.seconds);
  write_file_atomically(path, csv);
}

void write_loss_png(const std::string& path, const std::vector<EpochStats>& epochs) {
  constexpr int kW = 640, kH = 400, kMargin = 40;
  Image image(kW, kH);
  for (Vec3& p : image.pixels) p = {1, 1, 1};
  double lo = 0, hi = 0;
  for (const EpochStats& e : epochs) hi = std::max({hi, e.loss, e.tree});
  if (!(hi > lo)) hi = 1;
  const int first = epochs.empty() ? 0 : epochs.front().epoch;
  const int last = epochs.empty() ? 1 : std::max(first + 1, epochs.back().epoch);
  const auto px = [&](double epoch) {
    return kMargin + (epoch - first) / (last - first) * (kW - 2 * kMargin);
  };
  const auto py = [&](double v) {
    return kH - kMargin - (v - lo) / (hi - lo) * (kH - 2 * kMargin);
  };
  const auto dot = [&](double x, double y, const Vec3& c, int r) {
    for (int dy = -r; dy <= r; ++dy)
      for (int dx = -r; dx <= r; ++dx) {
        const int ix = static_cast<int>(std::lround(x)) + dx,
                  iy = static_cast<int>(std::lround(y)) + dy;
        if (ix >= 0 && ix < kW && iy >= 0 && iy < kH) image.at(ix, iy) = c;
      }
  };
  const auto line = [&](double x0, double y0, double x1, double y1, const Vec3& c, int r) {
    const int steps = static_cast<int>(std::max(std::fabs(x1 - x0), std::fabs(y1 - y0))) + 1;
    for (int s = 0; s <= steps; ++s) {
      const double t = static_cast<double>(s) / steps;
      dot(x0 + t * (x1 - x0), y0 + t * (y1 - y0), c, r);
    }
  };
  const Vec3 grid{0.85f, 0.85f, 0.85f}, axis{0, 0, 0};
  for (int i = 0; i <= 10; ++i) {  // horizontal grid lines at tenths of the range
    const double y = py(lo + (hi - lo) * i / 10);
    line(kMargin, y, kW - kMargin, y, grid, 0);
  }
  for (int e = first; e <= last; ++e) line(px(e), kH - kMargin, px(e), kH - kMargin + 5, axis, 0);
  line(kMargin, kH - kMargin, kW - kMargin, kH - kMargin, axis, 0);
  line(kMargin, kMargin, kMargin, kH - kMargin, axis, 0);
  const Vec3 red{0.85f, 0.1f, 0.1f}, blue{0.1f, 0.2f, 0.85f};
  for (std::size_t i = 0; i < epochs.size(); ++i) {
    const EpochStats& e = epochs[i];
    if (i > 0) {
      const EpochStats& p = epochs[i - 1];
      line(px(p.epoch), py(p.loss), px(e.epoch), py(e.loss), red, 1);
      line(px(p.epoch), py(p.tree), px(e.epoch), py(e.tree), blue, 1);
    }
    dot(px(e.epoch), py(e.loss), red, 3);
    dot(px(e.epoch), py(e.tree), blue, 3);
  }
  write_png(path, image);
}

}  // namespace splitray::train

#include "loss_report.hpp"

#include <fmt/core.h>

#include "splitray/core/image.hpp"
#include "splitray/io/plot_script.hpp"

namespace splitray::train {

void write_loss_csv(const std::string& path, const std::vector<EpochStats>& epochs) {
  std::string csv = "epoch,loss,tree_loss,bound_loss,mean_relative_cost,seconds\n";
  for (const EpochStats& e : epochs)
    csv += fmt::format("{},{:.8g},{:.8g},{:.8g},{:.8g},{:.2f}\n", e.epoch, e.loss, e.tree, e.bound,
                       e.cost, e.seconds);
  write_file_atomically(path, csv);
}

void write_loss_png(const std::string& path, const std::string& csv_path) {
  run_plot_script("plot_loss.py", path, csv_path);
}

}  // namespace splitray::train

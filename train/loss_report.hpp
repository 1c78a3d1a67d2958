#pragma once
// The loss per epoch as CSV and as a PNG plot (scripts/plot_loss.py: axes, labels, legend).
#include <string>
#include <vector>

#include "trainer.hpp"

namespace splitray::train {

void write_loss_csv(const std::string& path, const std::vector<EpochStats>& epochs);
// The plot of a CSV of write_loss_csv (Debian's python3-matplotlib); atomic like the CSV.
void write_loss_png(const std::string& path, const std::string& csv_path);

}  // namespace splitray::train

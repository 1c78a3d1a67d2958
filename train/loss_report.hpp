#pragma once
// The loss per epoch as CSV and as a PNG plot (drawn with the project's image code, so that
// no plotting package is needed).
#include <string>
#include <vector>

#include "trainer.hpp"

namespace splitray::train {

void write_loss_csv(const std::string& path, const std::vector<EpochStats>& epochs);
// Total loss (red) and tree term (blue) against the epoch, on a grid of tenths; both atomic.
void write_loss_png(const std::string& path, const std::vector<EpochStats>& epochs);

}  // namespace splitray::train

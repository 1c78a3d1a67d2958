#pragma once
// A one-line progress bar on stderr, drawn only when stderr is a terminal so that logs and
// pipes stay clean.
#include <chrono>
#include <string>

namespace splitray::app {

class ProgressBar {
 public:
  explicit ProgressBar(std::string label);
  ~ProgressBar();  // clears the line if it was drawn
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  // Shows `text` in place of the bar until the first update (e.g. while building).
  void status(const std::string& text);
  // Redraws when the shown percentage changes; `fraction` in [0, 1]. The time shown counts
  // from the first update.
  void update(double fraction);
  void finish();

 private:
  std::string label_;
  bool enabled_;
  bool drawn_ = false;
  int shown_permille_ = -1;
  std::size_t status_width_ = 0;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace splitray::app

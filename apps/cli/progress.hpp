#pragma once
// Progress on stderr: on a terminal a one-line bar redrawn in place; otherwise (logs, pipes,
// CI) one line per finished step and per tenth of the work, so that logs stay readable.
#include <chrono>
#include <string>

namespace splitray::cli {

class ProgressBar {
 public:
  explicit ProgressBar(std::string label);
  ~ProgressBar();  // clears the bar (terminal) or reports the last step (log)
  ProgressBar(const ProgressBar&) = delete;
  ProgressBar& operator=(const ProgressBar&) = delete;

  // The step now under way (e.g. "building kd ..."). A terminal shows it until the next call;
  // a log gets one line for it once it has finished (so a failed step prints nothing, and
  // the error is the first line).
  void status(const std::string& text);
  // The share of the main work done, `fraction` in [0, 1]; the time counts from the first call.
  void update(double fraction);
  void finish();

 private:
  void finish_step();

  std::string label_;
  bool terminal_;
  bool drawn_ = false;
  int shown_permille_ = -1;
  std::size_t status_width_ = 0;
  std::string step_;  // log: the step under way, reported when it ends
  std::chrono::steady_clock::time_point start_, step_start_;
};

}  // namespace splitray::cli

#include "progress.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <exception>

namespace splitray::cli {

namespace {
constexpr int kBarWidth = 30;

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}
}  // namespace

ProgressBar::ProgressBar(std::string label)
    : label_(std::move(label)),
      terminal_(isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()),
      step_start_(start_) {}

ProgressBar::~ProgressBar() {
  if (std::uncaught_exceptions() > 0) step_.clear();  // a failed step is not reported done
  finish();
}

void ProgressBar::finish_step() {
  if (step_.empty()) return;
  fmt::print(stderr, "{}: {} done ({:.1f} s)\n", label_, step_, seconds_since(step_start_));
  std::fflush(stderr);
  step_.clear();
}

void ProgressBar::status(const std::string& text) {
  if (!terminal_) {
    finish_step();
    step_ = text;
    step_start_ = std::chrono::steady_clock::now();
    return;
  }
  fmt::print(stderr, "\r{} {}", label_, text);
  std::fflush(stderr);
  status_width_ = label_.size() + 1 + text.size();
  drawn_ = true;
}

void ProgressBar::update(double fraction) {
  const int permille = static_cast<int>(std::clamp(fraction, 0.0, 1.0) * 1000);
  if (!terminal_) {
    finish_step();
    if (shown_permille_ < 0) start_ = std::chrono::steady_clock::now();
    if (shown_permille_ >= 0 && permille / 100 == shown_permille_ / 100) return;
    shown_permille_ = permille;
    fmt::print(stderr, "{}: {:3d}% ({:.1f} s)\n", label_, permille / 10, seconds_since(start_));
    std::fflush(stderr);
    return;
  }
  if (shown_permille_ < 0) {
    start_ = std::chrono::steady_clock::now();
    finish();  // clear the status text
  }
  if (permille / 10 == shown_permille_ / 10 && drawn_) return;  // redraw once per percent
  shown_permille_ = permille;
  const int filled = permille * kBarWidth / 1000;
  fmt::print(stderr, "\r{} [{}{}] {:3d}%  {:.1f} s", label_, std::string(filled, '#'),
             std::string(kBarWidth - filled, '-'), permille / 10, seconds_since(start_));
  std::fflush(stderr);
  drawn_ = true;
}

void ProgressBar::finish() {
  if (!terminal_) {
    finish_step();
    return;
  }
  if (!drawn_) return;
  // Clear the bar so that the summary that follows starts on a clean line.
  const std::size_t width = std::max(status_width_, label_.size() + kBarWidth + 20);
  fmt::print(stderr, "\r{}\r", std::string(width, ' '));
  std::fflush(stderr);
  drawn_ = false;
}

}  // namespace splitray::cli

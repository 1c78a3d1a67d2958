#include "progress.hpp"

#include <fmt/core.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace splitray::app {

namespace {
constexpr int kBarWidth = 30;
}

ProgressBar::ProgressBar(std::string label)
    : label_(std::move(label)), enabled_(isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()) {}

ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::status(const std::string& text) {
  if (!enabled_) return;
  fmt::print(stderr, "\r{} {}", label_, text);
  std::fflush(stderr);
  status_width_ = label_.size() + 1 + text.size();
  drawn_ = true;
}

void ProgressBar::update(double fraction) {
  if (!enabled_) return;
  if (shown_permille_ < 0) {
    start_ = std::chrono::steady_clock::now();
    finish();  // clear the status text
  }
  const int permille = static_cast<int>(std::clamp(fraction, 0.0, 1.0) * 1000);
  if (permille / 10 == shown_permille_ / 10 && drawn_) return;  // redraw once per percent
  shown_permille_ = permille;
  const int filled = permille * kBarWidth / 1000;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  fmt::print(stderr, "\r{} [{}{}] {:3d}%  {:.1f} s", label_, std::string(filled, '#'),
             std::string(kBarWidth - filled, '-'), permille / 10, seconds);
  std::fflush(stderr);
  drawn_ = true;
}

void ProgressBar::finish() {
  if (!drawn_) return;
  // Clear the bar so that the summary that follows starts on a clean line.
  const std::size_t width = std::max(status_width_, label_.size() + kBarWidth + 20);
  fmt::print(stderr, "\r{}\r", std::string(width, ' '));
  std::fflush(stderr);
  drawn_ = false;
}

}  // namespace splitray::app

#pragma once
// An adaptive Wiener (FIR) predictor whose taps are adapted by normalised LMS (paper 000 §4,
// eqs. 13-16: order 6, step 0.5). It filters the signal's increments rather than the signal
// itself: increments carry no offset (which would dominate LMS's normalisation and slow it),
// and all-zero taps then predict "no change", a safe start.
#include <array>

namespace splitray {

inline constexpr int kWienerMaxOrder = 16;

struct WienerConfig {
  int order = 6;      // taps, at most kWienerMaxOrder
  double step = 0.5;  // mu of normalised LMS, in (0, 2)
  double regularization =
      1e-6;  // added to the input power: tiny increments must not blow up the taps
};

class WienerPredictor {
 public:
  WienerPredictor() = default;
  // Starts at the first observation `z`, all taps zero.
  WienerPredictor(const WienerConfig& config, double z);

  // y(n): the next observation predicted from the past increments (eq. 15).
  double predict() const;
  // d(n) = z: the error e = d - y adapts the taps (eq. 16, normalised), then z joins the past.
  void update(double z);

  double last() const { return last_; }
  const std::array<double, kWienerMaxOrder>& taps() const { return w_; }

 private:
  WienerConfig config_;
  double last_ = 0;
  std::array<double, kWienerMaxOrder> w_{};
  std::array<double, kWienerMaxOrder> u_{};  // u_[i] = increment i + 1 steps ago
};

}  // namespace splitray

#include "splitray/accel/predict/wiener.hpp"

#include <algorithm>

#include "splitray/core/errors.hpp"

namespace splitray {

WienerPredictor::WienerPredictor(const WienerConfig& config, double z) : config_(config), last_(z) {
  if (config.order < 1 || config.order > kWienerMaxOrder)
    throw Error("Wiener predictor", "order must be in 1.." + std::to_string(kWienerMaxOrder));
  if (!(config.step > 0 && config.step < 2))
    throw Error("Wiener predictor", "the LMS step must be in (0, 2)");
}

double WienerPredictor::predict() const {
  double y = 0;
  for (int i = 0; i < config_.order; ++i) y += w_[i] * u_[i];
  return last_ + y;
}

void WienerPredictor::update(double z) {
  const double d = z - last_;  // desired increment
  double y = 0, power = config_.regularization;
  for (int i = 0; i < config_.order; ++i) {
    y += w_[i] * u_[i];
    power += u_[i] * u_[i];
  }
  const double e = d - y;
  const double gain = config_.step * e / power;
  for (int i = 0; i < config_.order; ++i) w_[i] += gain * u_[i];
  std::copy_backward(u_.begin(), u_.begin() + config_.order - 1, u_.begin() + config_.order);
  u_[0] = d;
  last_ = z;
}

}  // namespace splitray

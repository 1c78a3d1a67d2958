#include "splitray/accel/predict/kalman.hpp"

namespace splitray {

namespace {

struct Prior {
  double x[2];
  double p[2][2];
};

// x- = A x, P- = A P A^T + Q for A = [[1, 1], [0, 1]].
Prior time_update(const double x[2], const double p[2][2], double q) {
  Prior r;
  r.x[0] = x[0] + x[1];
  r.x[1] = x[1];
  const double p00 = p[0][0] + p[0][1] + p[1][0] + p[1][1];
  const double p01 = p[0][1] + p[1][1];
  const double p10 = p[1][0] + p[1][1];
  r.p[0][0] = p00 + 0.25 * q;
  r.p[0][1] = p01 + 0.5 * q;
  r.p[1][0] = p10 + 0.5 * q;
  r.p[1][1] = p[1][1] + q;
  return r;
}

}  // namespace

KalmanFilter::KalmanFilter(const KalmanConfig& config, double z) : config_(config) {
  x_[0] = z;
  x_[1] = 0;
  p_[0][0] = config.measurement_noise;
  p_[1][1] = config.initial_velocity_variance;
}

KalmanPrediction KalmanFilter::predict() const {
  const Prior prior = time_update(x_, p_, config_.process_noise);
  return {prior.x[0], prior.p[0][0] + config_.measurement_noise};
}

void KalmanFilter::update(double z) {
  const Prior prior = time_update(x_, p_, config_.process_noise);
  const double s = prior.p[0][0] + config_.measurement_noise;
  const double k0 = prior.p[0][0] / s, k1 = prior.p[1][0] / s;  // gain K = P- H^T / S
  const double innovation = z - prior.x[0];
  x_[0] = prior.x[0] + k0 * innovation;
  x_[1] = prior.x[1] + k1 * innovation;
  // P = (I - K H) P-
  p_[0][0] = (1 - k0) * prior.p[0][0];
  p_[0][1] = (1 - k0) * prior.p[0][1];
  p_[1][0] = prior.p[1][0] - k1 * prior.p[0][0];
  p_[1][1] = prior.p[1][1] - k1 * prior.p[0][1];
}

}  // namespace splitray

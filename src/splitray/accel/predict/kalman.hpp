#pragma once
// A constant-velocity Kalman filter over one scalar (paper 000 §4, eqs. 6-10): the state is
// (position, velocity), A = [[1, 1], [0, 1]], H = [1, 0], Q = q * [[1/4, 1/2], [1/2, 1]]
// (a random acceleration per step), R = r. predict() is the time update without changing
// the filter, so many readers may ask for the next position while nobody updates it.
namespace splitray {

struct KalmanConfig {
  double process_noise = 1e-4;      // q: variance of the acceleration per frame
  double measurement_noise = 1e-5;  // r: variance of an observed position
  double initial_velocity_variance = 1e-3;
};

struct KalmanPrediction {
  double position = 0;
  double variance = 0;  // of the predicted observation: H P- H^T + R
};

class KalmanFilter {
 public:
  KalmanFilter() = default;
  // Starts at the first frame's observation `z` with zero velocity (the paper's start from
  // the first frame; its random virtual observations are replaced by a velocity variance,
  // so that results are reproducible).
  KalmanFilter(const KalmanConfig& config, double z);

  // The next observation as the model expects it (time update, eq. 9).
  KalmanPrediction predict() const;
  // Time update, then measurement update with the observation `z` (eq. 10).
  void update(double z);

  double position() const { return x_[0]; }
  double velocity() const { return x_[1]; }

 private:
  KalmanConfig config_;
  double x_[2] = {0, 0};
  double p_[2][2] = {{0, 0}, {0, 0}};
};

}  // namespace splitray

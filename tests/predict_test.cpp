// The predictors of animated kd rebuilds (paper 000 §4): the constant-velocity Kalman filter
// and the LMS-adapted Wiener filter, and the per-node SplitPredictor built on them.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "splitray/accel/predict/kalman.hpp"
#include "splitray/accel/predict/split_predictor.hpp"
#include "splitray/accel/predict/wiener.hpp"
#include "splitray/core/errors.hpp"

namespace splitray {
namespace {

TEST(Kalman, ConvergesToConstantVelocitySignal) {
  KalmanFilter f(KalmanConfig{}, 0.2);
  double first_error = 0, last_error = 0;
  for (int k = 1; k <= 60; ++k) {
    const double z = 0.2 + 0.01 * k;
    const double error = std::abs(f.predict().position - z);
    if (k == 1) first_error = error;  // zero velocity at the start
    last_error = error;
    f.update(z);
  }
  EXPECT_GT(first_error, 0.005);
  EXPECT_LT(last_error, 1e-4);
  EXPECT_NEAR(f.velocity(), 0.01, 1e-4);
  EXPECT_NEAR(f.position(), 0.8, 1e-4);
}

TEST(Kalman, PredictionVarianceShrinksWithObservations) {
  KalmanFilter f(KalmanConfig{}, 0.5);
  const double before = f.predict().variance;
  for (int k = 0; k < 20; ++k) f.update(0.5);
  EXPECT_LT(f.predict().variance, before);
  EXPECT_GT(f.predict().variance, KalmanConfig{}.measurement_noise);  // never below R
}

TEST(Wiener, LmsReducesErrorOnSinusoid) {
  const auto signal = [](int n) { return 0.5 + 0.1 * std::sin(0.3 * n); };
  WienerPredictor w(WienerConfig{}, signal(0));  // order 6, step 0.5
  double early = 0, late = 0;
  for (int n = 1; n <= 400; ++n) {
    const double e = signal(n) - w.predict();
    if (n <= 20) early += e * e;
    if (n > 380) late += e * e;
    w.update(signal(n));
  }
  EXPECT_LT(late, early * 1e-3);
  EXPECT_GT(early, 0);
}

TEST(Wiener, StartsPredictingNoChangeAndRejectsBadSettings) {
  WienerPredictor w(WienerConfig{}, 0.25);
  EXPECT_EQ(w.predict(), 0.25);
  WienerConfig bad;
  bad.order = 0;
  EXPECT_THROW(WienerPredictor(bad, 0), Error);
  bad.order = 6;
  bad.step = 2.5;
  EXPECT_THROW(WienerPredictor(bad, 0), Error);
}

TEST(SplitPredictor, PathsAndPredictions) {
  EXPECT_EQ(path_child(kRootPath, false), 2u);
  EXPECT_EQ(path_child(kRootPath, true), 3u);
  std::uint64_t deep = kRootPath;
  for (int d = 0; d < 62; ++d) deep = path_child(deep, true);
  EXPECT_NE(deep, 0u);
  EXPECT_EQ(path_child(deep, false), 0u);  // too deep for a code

  for (const PredictorKind kind : {PredictorKind::kalman, PredictorKind::wiener}) {
    PredictorConfig config;
    config.kind = kind;
    SplitPredictor p(config);
    EXPECT_FALSE(p.predict(kRootPath, 0));
    for (int frame = 0; frame < 12; ++frame) {
      SplitObservation o;
      o.path = kRootPath;
      o.axis = 1;
      o.fraction = 0.4 + 0.005 * frame;
      o.axis_margin = 0.5;
      p.update(std::span<const SplitObservation>(&o, 1));
    }
    const auto pred = p.predict(kRootPath, 0);
    ASSERT_TRUE(pred) << predictor_name(kind);
    EXPECT_EQ(pred->axis, 1);
    EXPECT_NEAR(pred->fraction, 0.46, 0.01) << predictor_name(kind);
    EXPECT_GE(pred->half_width, config.min_half_width);
    EXPECT_FALSE(p.predict(kRootPath, 3));  // depth mismatch
    // A node not observed in a frame is forgotten.
    p.update({});
    EXPECT_FALSE(p.predict(kRootPath, 0));
  }
  PredictorConfig off;
  off.kind = PredictorKind::none;
  SplitPredictor none(off);
  SplitObservation o;
  o.path = kRootPath;
  none.update(std::span<const SplitObservation>(&o, 1));
  EXPECT_FALSE(none.predict(kRootPath, 0));
  EXPECT_THROW(parse_predictor_kind("kalmann"), Error);
}

}  // namespace
}  // namespace splitray

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

// Many nodes (the index grows past its first size), nodes dropping out and coming back:
// every live node predicts from its own history, a node unseen for a frame starts afresh.
TEST(SplitPredictor, ManyNodesAreTrackedAndForgotten) {
  PredictorConfig config;
  config.kind = PredictorKind::kalman;
  SplitPredictor p(config);
  const auto frame = [&](std::uint64_t first, std::uint64_t count, double shift) {
    std::vector<SplitObservation> obs;
    for (std::uint64_t path = first; path < first + count; ++path) {
      SplitObservation o;
      o.path = path;
      o.depth = 3;
      o.axis = static_cast<int>(path % 3);
      o.fraction = 0.3 + 0.0001 * static_cast<double>(path % 1000) + shift;
      o.axis_margin = 0.5;
      obs.push_back(o);
    }
    p.update(obs);
  };
  for (int f = 0; f < 5; ++f) frame(8, 5000, 0.01 * f);
  EXPECT_EQ(p.tracked(), 5000u);
  for (const std::uint64_t path : {8ull, 999ull, 5007ull}) {
    const auto pred = p.predict(path, 3);
    ASSERT_TRUE(pred) << path;
    EXPECT_EQ(pred->axis, static_cast<int>(path % 3));
    // Constant velocity 0.01 per frame: the next is about 0.05 past the first frame's.
    EXPECT_NEAR(pred->fraction, 0.3 + 0.0001 * static_cast<double>(path % 1000) + 0.05, 0.01);
  }
  EXPECT_FALSE(p.predict(5008, 3));
  frame(8, 2500, 0.05);  // half the nodes vanish
  EXPECT_EQ(p.tracked(), 2500u);
  EXPECT_TRUE(p.predict(100, 3));
  EXPECT_FALSE(p.predict(4000, 3));
  frame(8, 5000, 0.06);  // they come back: their filters restart at this frame's split
  const auto fresh = p.predict(4000, 3);
  ASSERT_TRUE(fresh);
  EXPECT_NEAR(fresh->fraction, 0.3 + 0.0001 * 0 + 0.06, 1e-9);
  EXPECT_EQ(p.tracked(), 5000u);
}

}  // namespace
}  // namespace splitray

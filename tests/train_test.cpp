// The training side of the neural builder (train/, libtorch; built only where libtorch is):
// the intent of the two custom gradients of paper 003 §5 checked by finite differences, the
// plain C++ forward pass against libtorch's on the SHIPPED weights, and a short training run
// that lowers the loss.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "splitray/accel/neural/neural_model.hpp"
#include "splitray/core/random.hpp"
#include "test_data.hpp"
#include "torch_train.hpp"
#include "train_data.hpp"
#include "trainer.hpp"

namespace splitray::test {
namespace {

using train::count_slopes;

// -t log Σ exp(-c / t): the function whose gradient the soft minimum's backward is.
double negative_lse(const std::vector<double>& c, double t) {
  double m = c[0];
  for (double x : c) m = std::min(m, x);
  double s = 0;
  for (double x : c) s += std::exp(-(x - m) / t);
  return m - t * std::log(s);
}

TEST(SoftMin, ForwardIsTheHardMinimumAndBackwardTheSoftmaxFiniteDifferenceOfNegativeLse) {
  const double t = 0.5;
  const std::vector<double> c = {0.9, 0.7, 1.3, 0.75};
  torch::Tensor costs = torch::tensor({0.9, 0.7, 1.3, 0.75}, torch::kFloat64).view({1, 4});
  costs.set_requires_grad(true);
  const torch::Tensor m = train::soft_min(costs, t);
  EXPECT_DOUBLE_EQ(m.item<double>(), 0.7);
  m.sum().backward();
  const torch::Tensor g = costs.grad();
  double sum = 0;
  for (int i = 0; i < 4; ++i) {
    std::vector<double> hi = c, lo = c;
    const double h = 1e-6;
    hi[static_cast<std::size_t>(i)] += h;
    lo[static_cast<std::size_t>(i)] -= h;
    const double fd = (negative_lse(hi, t) - negative_lse(lo, t)) / (2 * h);
    EXPECT_NEAR(g[0][i].item<double>(), fd, 1e-6) << i;
    sum += g[0][i].item<double>();
  }
  EXPECT_NEAR(sum, 1.0, 1e-12);  // a softmax: all the upstream gradient, distributed
  EXPECT_GT(g[0][1].item<double>(), g[0][0].item<double>());  // most to the minimum
}

TEST(SoftMin, AbsentOptionsGetNoGradient) {
  const float inf = std::numeric_limits<float>::infinity();
  torch::Tensor costs = torch::tensor({0.5f, inf, 0.4f, inf}).view({1, 4});
  costs.set_requires_grad(true);
  train::soft_min(costs, 1.0).sum().backward();
  EXPECT_EQ(costs.grad()[0][1].item<float>(), 0.0f);
  EXPECT_EQ(costs.grad()[0][3].item<float>(), 0.0f);
  EXPECT_NEAR(costs.grad()[0][0].item<float>() + costs.grad()[0][2].item<float>(), 1.0f, 1e-6f);
}

// The exact count below a split (coordinate < split), the forward of replaced_count.
int count_below(const std::vector<float>& coords, float split) {
  int n = 0;
  for (float c : coords) n += c < split ? 1 : 0;
  return n;
}

TEST(ReplacedCount, GradientPointsTowardTheNextPointAndItsStepIsTheCountChange) {
  Pcg32 rng(5);
  std::vector<float> coords;
  for (int i = 0; i < 200; ++i) coords.push_back(rng.next_float());
  coords.push_back(coords[17]);  // a duplicate: two points at the same next coordinate
  const float e = 1e-3f;
  for (float split : {0.1f, 0.37f, 0.5f, coords[17] - 1e-4f, 0.93f}) {
    float up = 2, down = -1;
    for (float c : coords) {
      if (c >= split)
        up = std::min(up, c);
      else
        down = std::max(down, c);
    }
    const train::CountSlopes s = count_slopes(coords, split, e);
    // Below: moving the split up by the gap to the next point (and a hair) takes in n points;
    // the replacement slope is that finite difference n / gap, bounded by e.
    const float step_up = std::nextafter(up, 2.0f) - split;
    const int n_up = count_below(coords, split + step_up) - count_below(coords, split);
    EXPECT_GT(s.below, 0.0f);
    EXPECT_NEAR(s.below, n_up / ((up - split) + e), 1e-3f * s.below) << split;
    if (split == coords[17] - 1e-4f) {
      EXPECT_EQ(n_up, 2);
    }
    // Above: the count above grows when the split moves down past the previous point.
    const int n_down = count_below(coords, split) - count_below(coords, down);
    EXPECT_LT(s.above, 0.0f);
    EXPECT_NEAR(s.above, -n_down / ((split - down) + e), 1e-3f * -s.above) << split;
  }
  // Nothing above the split: no point to move toward, no gradient.
  EXPECT_EQ(count_slopes(coords, 1.5f, e).below, 0.0f);

  // The autograd function: exact counts forward, the slopes backward.
  torch::Tensor split = torch::tensor({0.3f, 0.6f});
  split.set_requires_grad(true);
  const torch::Tensor counts = torch::tensor({12.0f, 40.0f}), slopes = torch::tensor({80.0f, 5.0f});
  const torch::Tensor n = train::replaced_count(split, counts, slopes);
  EXPECT_TRUE(torch::equal(n, counts));
  n.sum().backward();
  EXPECT_TRUE(torch::allclose(split.grad(), slopes));
}

std::string shipped(const std::string& name) {
  return std::string(SPLITRAY_SOURCE_DIR) + "/models/" + name;
}

TEST(ShippedModels, PlainForwardPassEqualsLibtorchTo1e5) {
  for (const std::string name : {"sah.bin", "vvh.bin"}) {
    ASSERT_TRUE(std::filesystem::exists(shipped(name))) << shipped(name) << " is not shipped";
    const NeuralModel model = read_neural_model(shipped(name));
    train::Net net = train::import_model(model);
    torch::NoGradGuard no_grad;
    Pcg32 rng(9);
    for (int level = 0; level < model.depth(); ++level) {
      // Groups as inference makes them: 2048 split among nodes, values in [1, 2], some
      // clustered, some at the ends, one group of two points.
      std::vector<float> coords;
      std::vector<std::size_t> offsets = {0};
      std::vector<int64_t> group;
      const int sizes[] = {2048, 700, 64, 2, 333};
      for (int g = 0; g < 5; ++g) {
        for (int i = 0; i < sizes[g]; ++i) {
          float x = 1 + (g == 2 ? 0.1f * rng.next_float() + 0.45f : rng.next_float());
          if (i == 0) x = 1;
          if (i == 1) x = 2;
          coords.push_back(x);
          group.push_back(g);
        }
        offsets.push_back(coords.size());
      }
      std::vector<float> plain(5), scratch;
      encode_groups(model.levels[static_cast<std::size_t>(level)], model.pooling, coords, offsets,
                    plain, scratch);
      const torch::Tensor ref = net->levels[static_cast<std::size_t>(level)]->forward(
          torch::from_blob(coords.data(), {static_cast<int64_t>(coords.size())}).clone(),
          torch::from_blob(group.data(), {static_cast<int64_t>(group.size())}, torch::kInt64)
              .clone(),
          5);
      for (int g = 0; g < 5; ++g)
        EXPECT_NEAR(plain[static_cast<std::size_t>(g)], ref[g].item<float>(), 1e-5f)
            << name << " level " << level << " group " << g;
    }
  }
}

TEST(Training, AShortRunLowersTheLoss) {
  train::DataOptions d;
  d.points = 128;
  d.tree_depth = 1;
  d.rotations = 1;
  d.pool = 20000;
  const std::vector<train::TrainSet> sets =
      train::build_training_sets({vendored_file("horse/horse.obj.gz")}, d);
  ASSERT_EQ(sets.size(), 6u);  // root + 2 children, each also rotated once
  train::TrainOptions t;
  t.depth = 3;
  t.lookahead = 0;  // the full expansion from the root
  t.epochs = 30;
  t.batch = 2;
  t.lr = 1e-3;
  t.width = 8;
  const train::TrainResult r = train::train_model(sets, t);
  ASSERT_EQ(r.epochs.size(), 31u);  // epoch 0 = the untrained network, no update
  EXPECT_EQ(r.model.depth(), 3);
  EXPECT_EQ(r.model.points, 2048);
  for (const train::EpochStats& e : r.epochs) EXPECT_TRUE(std::isfinite(e.loss));
  // The exported weights, evaluated like epoch 0 (no update), give a lower loss and cost.
  train::Net trained = train::import_model(r.model);
  train::CostOptions c;
  c.depth = 3;
  torch::NoGradGuard no_grad;
  double loss = 0, cost = 0;
  for (const train::TrainSet& set : sets) {
    const train::SetLoss l = train::tree_loss(trained, set, c);
    loss += (l.tree + l.bound).item<double>() / static_cast<double>(sets.size());
    cost += l.cost / static_cast<double>(sets.size());
  }
  EXPECT_LT(loss, r.epochs.front().loss);
  EXPECT_LT(cost, r.epochs.front().cost);
}

}  // namespace
}  // namespace splitray::test

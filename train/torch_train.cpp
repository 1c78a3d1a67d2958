#include "torch_train.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>

#include "splitray/core/errors.hpp"
#include "splitray/core/random.hpp"
#include "trainer.hpp"

namespace splitray::train {

namespace {

using torch::autograd::AutogradContext;
using torch::autograd::variable_list;
constexpr float kInf = std::numeric_limits<float>::infinity();

struct SoftMinFn : torch::autograd::Function<SoftMinFn> {
  static torch::Tensor forward(AutogradContext* ctx, const torch::Tensor& costs, double t) {
    ctx->save_for_backward({costs});
    ctx->saved_data["t"] = t;
    return std::get<0>(costs.min(1));
  }
  static variable_list backward(AutogradContext* ctx, variable_list grad) {
    const torch::Tensor costs = ctx->get_saved_variables()[0];
    const double t = ctx->saved_data["t"].toDouble();
    // -inf (absent options) get weight 0; every row has a finite option (the leaf).
    const torch::Tensor weights = torch::softmax(-costs / t, 1);
    return {grad[0].unsqueeze(1) * weights, torch::Tensor()};
  }
};

struct ReplacedCountFn : torch::autograd::Function<ReplacedCountFn> {
  static torch::Tensor forward(AutogradContext* ctx, const torch::Tensor& split,
                               const torch::Tensor& counts, const torch::Tensor& slopes) {
    (void)split;  // only its gradient is defined here
    ctx->save_for_backward({slopes});
    return counts.clone();
  }
  static variable_list backward(AutogradContext* ctx, variable_list grad) {
    return {grad[0] * ctx->get_saved_variables()[0], torch::Tensor(), torch::Tensor()};
  }
};

// SAH half area or VVH grown volume of boxes [n, 6] (lo xyz, hi xyz).
torch::Tensor measure(const torch::Tensor& boxes, NeuralCost cost, float radius) {
  const torch::Tensor e = boxes.slice(1, 3, 6) - boxes.slice(1, 0, 3);
  const torch::Tensor ex = e.select(1, 0), ey = e.select(1, 1), ez = e.select(1, 2);
  if (cost == NeuralCost::sah) return ex * ey + ey * ez + ez * ex;
  const float r2 = 2 * radius;
  return (ex + r2) * (ey + r2) * (ez + r2);
}

double measure_of(const float* b, NeuralCost cost, float radius) {
  const double ex = b[3] - b[0], ey = b[4] - b[1], ez = b[5] - b[2];
  if (!(ex >= 0 && ey >= 0 && ez >= 0)) return 0;
  if (cost == NeuralCost::sah) return ex * ey + ey * ez + ez * ex;
  const double r2 = 2.0 * radius;
  return (ex + r2) * (ey + r2) * (ez + r2);
}

// Huber loss of a non-negative distance d (0 inside the bounds), parameter delta (Eq. 9).
torch::Tensor huber(const torch::Tensor& d, double delta) {
  return torch::where(d < delta, 0.5 * d * d, delta * (d - 0.5 * delta));
}

torch::Tensor floats(const std::vector<float>& v) {
  return torch::from_blob(const_cast<float*>(v.data()), {static_cast<int64_t>(v.size())},
                          torch::kFloat32)
      .clone();
}

torch::Tensor longs(const std::vector<int64_t>& v) {
  return torch::from_blob(const_cast<int64_t*>(v.data()), {static_cast<int64_t>(v.size())},
                          torch::kInt64)
      .clone();
}

}  // namespace

torch::Tensor soft_min(const torch::Tensor& costs, double t) { return SoftMinFn::apply(costs, t); }

torch::Tensor replaced_count(const torch::Tensor& split, const torch::Tensor& counts,
                             const torch::Tensor& slopes) {
  return ReplacedCountFn::apply(split, counts, slopes);
}

CountSlopes count_slopes(const std::vector<float>& coords, float split, float e) {
  float up = kInf, down = -kInf;
  int n_up = 0, n_down = 0;
  for (const float c : coords) {
    if (c >= split) {
      if (c < up) {
        up = c;
        n_up = 1;
      } else if (c == up) {
        ++n_up;
      }
    } else if (c > down) {
      down = c;
      n_down = 1;
    } else if (c == down) {
      ++n_down;
    }
  }
  CountSlopes s;
  if (n_up > 0) s.below = static_cast<float>(n_up) / ((up - split) + e);
  if (n_down > 0) s.above = -static_cast<float>(n_down) / ((split - down) + e);
  return s;
}

EncoderImpl::EncoderImpl(int width, int point_layers, int head_layers) {
  int in = 1;
  for (int i = 0; i < point_layers; ++i) {
    point.push_back(register_module("point" + std::to_string(i), torch::nn::Linear(in, width)));
    in = width;
  }
  for (int i = 0; i < head_layers; ++i) {
    const int out = i + 1 == head_layers ? 1 : width;
    head.push_back(register_module("head" + std::to_string(i), torch::nn::Linear(in, out)));
    in = out;
  }
  for (auto& l : point)
    torch::nn::init::kaiming_uniform_(l->weight, 0, torch::kFanIn, torch::kReLU);
  for (std::size_t i = 0; i + 1 < head.size(); ++i)
    torch::nn::init::kaiming_uniform_(head[i]->weight, 0, torch::kFanIn, torch::kReLU);
  // The last layer starts near the middle of the tight bounds (λ' = 0.5) and small.
  torch::NoGradGuard no_grad;
  head.back()->weight.uniform_(-1e-2, 1e-2);
  head.back()->bias.fill_(0.5);
}

torch::Tensor EncoderImpl::forward(const torch::Tensor& coords, const torch::Tensor& group,
                                   int64_t groups) {
  // The first layer has in = 1: an outer product, done elementwise rather than through the
  // BLAS (Debian's reference sgemm dominates the training time otherwise).
  torch::Tensor x = torch::relu(coords.unsqueeze(1) * point[0]->weight.view({1, -1}) +
                                point[0]->bias.view({1, -1}));
  for (std::size_t i = 1; i < point.size(); ++i) x = torch::relu(point[i]->forward(x));
  const torch::Tensor sum = torch::zeros({groups, x.size(1)}).index_add(0, group, x);
  const torch::Tensor count =
      torch::zeros({groups}).index_add(0, group, torch::ones({coords.size(0)})).clamp_min(1);
  x = sum / count.unsqueeze(1);
  for (std::size_t i = 0; i < head.size(); ++i) {
    x = head[i]->forward(x);
    if (i + 1 < head.size()) x = torch::relu(x);
  }
  return x.squeeze(1);
}

NetImpl::NetImpl(int depth, int width, int point_layers, int head_layers) {
  for (int d = 0; d < depth; ++d)
    levels.push_back(
        register_module("level" + std::to_string(d), Encoder(width, point_layers, head_layers)));
}

namespace {

DenseLayer to_dense(const torch::nn::Linear& l, bool relu) {
  DenseLayer d;
  const torch::Tensor w = l->weight.detach().contiguous(), b = l->bias.detach().contiguous();
  d.out = static_cast<int>(w.size(0));
  d.in = static_cast<int>(w.size(1));
  d.activation = relu ? 1 : 0;
  d.weight.assign(w.data_ptr<float>(), w.data_ptr<float>() + w.numel());
  d.bias.assign(b.data_ptr<float>(), b.data_ptr<float>() + b.numel());
  return d;
}

void from_dense(torch::nn::Linear& l, const DenseLayer& d) {
  torch::NoGradGuard no_grad;
  l->weight.copy_(floats(d.weight).view({d.out, d.in}));
  l->bias.copy_(floats(d.bias));
}

}  // namespace

NeuralModel export_model(Net& net, NeuralCost cost, int points, const std::string& metadata) {
  NeuralModel m;
  m.cost = cost;
  m.points = points;
  m.pooling = NeuralPooling::mean;
  m.metadata = metadata;
  for (auto& level : net->levels) {
    LevelEncoder e;
    for (auto& l : level->point) e.point_layers.push_back(to_dense(l, true));
    for (std::size_t i = 0; i < level->head.size(); ++i)
      e.head_layers.push_back(to_dense(level->head[i], i + 1 < level->head.size()));
    m.levels.push_back(std::move(e));
  }
  return m;
}

Net import_model(const NeuralModel& model) {
  if (model.pooling != NeuralPooling::mean)
    throw Error("import_model", "only mean-pooling models are trained here");
  const LevelEncoder& first = model.levels.front();
  Net net(model.depth(), first.point_layers.front().out,
          static_cast<int>(first.point_layers.size()), static_cast<int>(first.head_layers.size()));
  for (int d = 0; d < model.depth(); ++d) {
    const LevelEncoder& e = model.levels[static_cast<std::size_t>(d)];
    auto& level = net->levels[static_cast<std::size_t>(d)];
    if (e.point_layers.size() != level->point.size() || e.head_layers.size() != level->head.size())
      throw Error("import_model", "levels of different shapes");
    for (std::size_t i = 0; i < e.point_layers.size(); ++i)
      from_dense(level->point[i], e.point_layers[i]);
    for (std::size_t i = 0; i < e.head_layers.size(); ++i)
      from_dense(level->head[i], e.head_layers[i]);
  }
  return net;
}

SetLoss tree_loss(Net& net, const TrainSet& set, const CostOptions& options) {
  const std::vector<Vec3>& pts = set.points;
  const int first = set.level;
  const int total = std::min<int>(options.depth, static_cast<int>(net->levels.size()));
  if (first < 0 || first >= total) throw Error(set.source, "set level outside the model's depth");
  const int depth =
      options.lookahead > 0 ? std::min(options.lookahead, total - first) : total - first;
  const NeuralCost kind = options.cost;
  const float radius = set.radius;

  // One level of the expanded tree: its nodes (entries = active sample indices, boxes with
  // their forward values, counts with their gradient) and the split options made below them.
  struct Level {
    std::vector<std::vector<std::uint32_t>> entries;
    std::vector<float> box;  // 6 per node: forward values
    torch::Tensor boxes, counts;
    std::vector<int64_t> opt_node, opt_axis;
    torch::Tensor w_left, w_right;
  };
  std::vector<Level> levels(1);
  {
    Level& root = levels[0];
    root.entries.emplace_back();
    for (std::size_t i = 0; i < pts.size(); ++i)
      if (set.root.contains(pts[i])) root.entries[0].push_back(static_cast<std::uint32_t>(i));
    root.box = {set.root.lo.x, set.root.lo.y, set.root.lo.z,
                set.root.hi.x, set.root.hi.y, set.root.hi.z};
    root.boxes = floats(root.box).view({1, 6});
    root.counts = torch::full({1}, static_cast<float>(root.entries[0].size()));
  }
  const double n_root = static_cast<double>(levels[0].entries[0].size());
  if (n_root < 1) throw Error(set.source, "no sample inside the set's root cell");
  const double scale = set.population > 0 ? set.population / static_cast<double>(pts.size()) : 1;
  const double ct_norm = options.traversal_cost / (options.intersection_cost * scale * n_root);

  SetLoss out;
  torch::Tensor bound = torch::zeros({});
  std::vector<float> coords, axis_coords, lo_t, ext_t;
  std::vector<int64_t> group;
  for (int k = 0; k < depth; ++k) {
    Level& lv = levels[static_cast<std::size_t>(k)];
    const std::size_t n = lv.entries.size();
    // The encoder's inputs: per node with >= 2 points and a positive measure, per axis with
    // extent, the active points normalised to their tight bounds in [1, 2] (as inference).
    coords.clear();
    group.clear();
    lo_t.clear();
    ext_t.clear();
    std::vector<int64_t> g_node, g_axis;
    for (std::size_t i = 0; i < n; ++i) {
      const std::vector<std::uint32_t>& e = lv.entries[i];
      if (e.size() < 2 || !(measure_of(&lv.box[6 * i], kind, radius) > 0)) continue;
      for (int axis = 0; axis < 3; ++axis) {
        float lo = kInf, hi = -kInf;
        for (const std::uint32_t p : e) {
          lo = std::min(lo, pts[p][axis]);
          hi = std::max(hi, pts[p][axis]);
        }
        const float extent = hi - lo;
        if (!(extent > 0)) continue;
        const auto g = static_cast<int64_t>(g_node.size());
        for (const std::uint32_t p : e) {
          coords.push_back(std::clamp(1.0f + (pts[p][axis] - lo) / extent, 1.0f, 2.0f));
          group.push_back(g);
        }
        g_node.push_back(static_cast<int64_t>(i));
        g_axis.push_back(axis);
        lo_t.push_back(lo);
        ext_t.push_back(extent);
      }
    }
    if (g_node.empty()) break;
    out.encoded += coords.size();
    const auto groups = static_cast<int64_t>(g_node.size());
    const torch::Tensor raw = net->levels[static_cast<std::size_t>(first + k)]->forward(
        floats(coords), longs(group), groups);
    // γ: the internal nodes below this level in the model's full top (Eq. 10).
    const double gamma = std::ldexp(1.0, total - (first + k)) - 1;
    bound = bound + gamma * (huber(torch::relu(-raw), options.huber) +
                             huber(torch::relu(raw - 1), options.huber))
                                .sum();
    const torch::Tensor lambda = raw.clamp(0, 1);  // outside: no gradient but the penalty's
    const torch::Tensor split_all = floats(lo_t) + lambda * floats(ext_t);
    const torch::Tensor lam_v = lambda.detach().contiguous();
    const float* lam = lam_v.data_ptr<float>();

    // The options whose split lies strictly inside the cell (inference skips the others).
    Level next;
    std::vector<int64_t> keep;
    std::vector<float> n_left, n_right, s_left, s_right, share_left, share_right;
    for (int64_t g = 0; g < groups; ++g) {
      const auto i = static_cast<std::size_t>(g_node[static_cast<std::size_t>(g)]);
      const int axis = static_cast<int>(g_axis[static_cast<std::size_t>(g)]);
      const float split =
          lo_t[static_cast<std::size_t>(g)] + lam[g] * ext_t[static_cast<std::size_t>(g)];
      const float* box = &lv.box[6 * i];
      if (!(split > box[axis] && split < box[3 + axis])) continue;
      std::vector<std::uint32_t> below, above;
      axis_coords.clear();
      for (const std::uint32_t p : lv.entries[i]) {
        const float c = pts[p][axis];
        axis_coords.push_back(c);
        (c < split ? below : above).push_back(p);
      }
      // e in units of the mean spacing of the node's points: n / (ε + e) is then an estimate
      // of the point density at the split (for Poisson spacing m, E[1 / (ε + m/2)] ≈ 0.92 / m).
      const float spacing =
          ext_t[static_cast<std::size_t>(g)] / static_cast<float>(lv.entries[i].size());
      const CountSlopes slopes = count_slopes(axis_coords, split, options.count_eps * spacing);
      const float total = static_cast<float>(lv.entries[i].size());
      keep.push_back(g);
      lv.opt_node.push_back(static_cast<int64_t>(i));
      lv.opt_axis.push_back(axis);
      n_left.push_back(static_cast<float>(below.size()));
      n_right.push_back(static_cast<float>(above.size()));
      s_left.push_back(slopes.below);
      s_right.push_back(slopes.above);
      share_left.push_back(static_cast<float>(below.size()) / total);
      share_right.push_back(static_cast<float>(above.size()) / total);
      for (int side = 0; side < 2; ++side) {
        next.box.insert(next.box.end(), box, box + 6);
        next.box[next.box.size() - 6 + (side == 0 ? 3 + axis : axis)] = split;
      }
      next.entries.push_back(std::move(below));
      next.entries.push_back(std::move(above));
    }
    if (keep.empty()) break;
    const torch::Tensor opt_node = longs(lv.opt_node);
    const torch::Tensor split = split_all.index_select(0, longs(keep));
    const torch::Tensor parent = lv.boxes.index_select(0, opt_node);
    const auto n_opt = static_cast<int64_t>(keep.size());
    // One-hot columns of the replaced bound: hi[axis] for the left child, lo[axis] for the right.
    torch::Tensor hi_mask = torch::zeros({n_opt, 6}), lo_mask = torch::zeros({n_opt, 6});
    {
      auto h = hi_mask.accessor<float, 2>(), l = lo_mask.accessor<float, 2>();
      for (int64_t o = 0; o < n_opt; ++o) {
        h[o][3 + lv.opt_axis[static_cast<std::size_t>(o)]] = 1;
        l[o][lv.opt_axis[static_cast<std::size_t>(o)]] = 1;
      }
    }
    const torch::Tensor s = split.unsqueeze(1);
    const torch::Tensor left = parent * (1 - hi_mask) + hi_mask * s;
    const torch::Tensor right = parent * (1 - lo_mask) + lo_mask * s;
    const torch::Tensor m_parent = measure(parent, kind, radius);
    lv.w_left = measure(left, kind, radius) / m_parent;
    lv.w_right = measure(right, kind, radius) / m_parent;
    // Counts: exact forward; backward the replacement slope for this split plus the parent
    // count's own gradient (upstream splits) in proportion to each child's share.
    const torch::Tensor pc = lv.counts.index_select(0, opt_node);
    const torch::Tensor upstream = pc - pc.detach();
    const torch::Tensor c_left =
        replaced_count(split, floats(n_left), floats(s_left)) + upstream * floats(share_left);
    const torch::Tensor c_right =
        replaced_count(split, floats(n_right), floats(s_right)) + upstream * floats(share_right);
    next.boxes = torch::stack({left, right}, 1).reshape({2 * n_opt, 6});
    next.counts = torch::stack({c_left, c_right}, 1).reshape({2 * n_opt});
    levels.push_back(std::move(next));
  }

  // Bottom-up (Eq. 4) in units of the root as one leaf: leaves N / N_root, internal
  // ct / (ci · scale · N_root) + w_L C_L + w_R C_R, the axis (or leaf) by soft_min.
  torch::Tensor cost = levels.back().counts / n_root;
  for (int k = static_cast<int>(levels.size()) - 2; k >= 0; --k) {
    const Level& lv = levels[static_cast<std::size_t>(k)];
    const auto n = static_cast<int64_t>(lv.entries.size());
    const torch::Tensor pair = cost.view({-1, 2});
    const torch::Tensor split_cost =
        ct_norm + lv.w_left * pair.select(1, 0) + lv.w_right * pair.select(1, 1);
    torch::Tensor table =
        torch::cat({(lv.counts / n_root).unsqueeze(1), torch::full({n, 3}, kInf)}, 1);
    table.index_put_({longs(lv.opt_node), longs(lv.opt_axis) + 1}, split_cost);
    cost = soft_min(table, options.sharpness);
  }
  out.cost = cost.item<double>();
  out.tree = cost.squeeze() * cost.squeeze();
  out.bound = bound;
  return out;
}

namespace {

std::size_t parameter_count(Net& net) {
  std::size_t n = 0;
  for (const torch::Tensor& p : net->parameters()) n += static_cast<std::size_t>(p.numel());
  return n;
}

}  // namespace

TrainResult train_model(const std::vector<TrainSet>& sets, const TrainOptions& options,
                        const std::function<void(double)>& progress,
                        const std::function<void(const EpochStats&)>& epoch_done) {
  if (sets.empty()) throw Error("--data", "no training sets");
  torch::set_num_threads(std::max(1, options.threads));
  torch::manual_seed(options.seed);
  Net net(options.depth, options.width, options.point_layers, options.head_layers);
  torch::optim::Adam adam(net->parameters(), torch::optim::AdamOptions(options.lr));
  CostOptions cost;
  cost.cost = options.cost;
  cost.depth = options.depth;
  cost.traversal_cost = options.traversal_cost;
  cost.intersection_cost = options.intersection_cost;
  cost.sharpness = options.sharpness;
  cost.count_eps = options.count_eps;
  cost.lookahead = options.lookahead;

  TrainResult result;
  result.parameters = parameter_count(net);
  const auto start = std::chrono::steady_clock::now();
  const auto seconds = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  const std::size_t batch = static_cast<std::size_t>(std::max(1, options.batch));
  const double total_steps = static_cast<double>(sets.size()) *
                             (options.epochs + (options.evaluate_initial ? 1.0 / 3 : 0.0));
  double done = 0;

  std::vector<std::size_t> order(sets.size());
  std::iota(order.begin(), order.end(), 0);
  Pcg32 rng(options.seed, 0x6f72646572);
  for (int epoch = options.evaluate_initial ? 0 : 1; epoch <= options.epochs; ++epoch) {
    EpochStats stats;
    stats.epoch = epoch;
    if (epoch == 0) {  // the starting point: loss of the untrained network, no update
      torch::NoGradGuard no_grad;
      for (const TrainSet& set : sets) {
        const SetLoss l = tree_loss(net, set, cost);
        stats.tree += l.tree.item<double>();
        stats.bound += l.bound.item<double>();
        stats.cost += l.cost;
        done += 1.0 / 3;
        if (progress) progress(done / total_steps);
      }
    } else {
      for (std::size_t i = sets.size(); i > 1; --i)  // Fisher-Yates with the portable PCG
        std::swap(order[i - 1], order[rng.next_u32() % i]);
      for (std::size_t b0 = 0; b0 < order.size(); b0 += batch) {
        const std::size_t b1 = std::min(order.size(), b0 + batch);
        adam.zero_grad();
        for (std::size_t b = b0; b < b1; ++b) {
          const SetLoss l = tree_loss(net, sets[order[b]], cost);
          const torch::Tensor loss = (l.tree + l.bound) / static_cast<double>(b1 - b0);
          loss.backward();
          stats.tree += l.tree.item<double>();
          stats.bound += l.bound.item<double>();
          stats.cost += l.cost;
          done += 1;
          if (progress) progress(done / total_steps);
        }
        torch::nn::utils::clip_grad_norm_(net->parameters(), 1.0);
        adam.step();
      }
    }
    const double n = static_cast<double>(sets.size());
    stats.tree /= n;
    stats.bound /= n;
    stats.cost /= n;
    stats.loss = stats.tree + stats.bound;
    stats.seconds = seconds();
    result.epochs.push_back(stats);
    if (epoch_done) epoch_done(stats);
  }
  result.model = export_model(net, options.cost, options.infer_points, "");
  return result;
}

}  // namespace splitray::train

#include "evaluate.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "greedy_top.hpp"

namespace splitray::train {

nlohmann::ordered_json evaluate(const NeuralModel& model, const std::vector<TrainSet>& sets,
                                const TrainOptions& options) {
  double sum_ratio = 0, sum_neural = 0, sum_greedy = 0, worst = 0, ms = 0;
  std::map<std::string, std::pair<double, int>> per_mesh;  // ratio sums per source mesh
  for (const TrainSet& set : sets) {
    NeuralTopOptions o;
    o.cost = options.cost;
    o.traversal_cost = options.traversal_cost;
    o.intersection_cost = options.intersection_cost;
    o.radius = set.radius;
    o.population = set.population;
    o.max_depth = model.depth();
    const NeuralTop neural = infer_neural_top(model, set.points, set.root, o);
    const NeuralTop greedy = greedy_top(set.points, set.root, o);
    const double cn = normalised_top_cost(neural, set.points, o);
    const double cg = normalised_top_cost(greedy, set.points, o);
    const double ratio = cn / cg;
    sum_ratio += ratio;
    sum_neural += cn;
    sum_greedy += cg;
    worst = std::max(worst, ratio);
    ms += neural.inference_cpu_ms;
    const std::string mesh = set.source.substr(0, set.source.find(' '));
    per_mesh[mesh].first += ratio;
    per_mesh[mesh].second += 1;
  }
  const double n = std::max<double>(1, static_cast<double>(sets.size()));
  nlohmann::ordered_json j;
  j["sets"] = sets.size();
  j["points"] = sets.empty() ? 0 : sets.front().points.size();
  j["mean_neural_cost"] = sum_neural / n;  // relative to the root as one leaf
  j["mean_greedy_cost"] = sum_greedy / n;
  j["mean_ratio_neural_over_greedy"] = sum_ratio / n;
  j["worst_ratio"] = worst;
  j["mean_inference_cpu_ms"] = ms / n;
  nlohmann::ordered_json meshes = nlohmann::ordered_json::object();
  for (const auto& [mesh, s] : per_mesh) meshes[mesh] = s.first / s.second;
  j["ratio_per_mesh"] = meshes;
  return j;
}

}  // namespace splitray::train

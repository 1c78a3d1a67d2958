#include "splitray/accel/build_options.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "splitray/core/errors.hpp"

namespace splitray {

namespace {

// An option of BuildConfig: its command-line name, whether a config sets it to other than the
// default, and its value for the range check (NaN when it has none, as for names).
struct Field {
  const char* name;
  bool (*set)(const BuildConfig&);
  double (*value)(const BuildConfig&);
};

const BuildConfig& defaults() {
  static const BuildConfig config;
  return config;
}

double no_value(const BuildConfig&) { return std::nan(""); }

const Field kFields[] = {
    {"--kt", [](const BuildConfig& c) { return c.traversal_cost.has_value(); },
     [](const BuildConfig& c) { return double(c.traversal_cost.value_or(1)); }},
    {"--ki", [](const BuildConfig& c) { return c.intersection_cost.has_value(); },
     [](const BuildConfig& c) { return double(c.intersection_cost.value_or(1)); }},
    {"--threads", [](const BuildConfig& c) { return c.threads != defaults().threads; },
     [](const BuildConfig& c) { return double(c.threads); }},
    {"--empty-bonus", [](const BuildConfig& c) { return c.empty_bonus != defaults().empty_bonus; },
     [](const BuildConfig& c) { return double(c.empty_bonus); }},
    {"--tree-depth", [](const BuildConfig& c) { return c.max_depth != defaults().max_depth; },
     [](const BuildConfig& c) { return double(c.max_depth); }},
    {"--leaf-size",
     [](const BuildConfig& c) { return c.max_leaf_prims != defaults().max_leaf_prims; },
     [](const BuildConfig& c) { return double(c.max_leaf_prims); }},
    {"--bins", [](const BuildConfig& c) { return c.bins != defaults().bins; },
     [](const BuildConfig& c) { return double(c.bins); }},
    {"--model", [](const BuildConfig& c) { return !c.neural.model.empty(); }, no_value},
    {"--expand", [](const BuildConfig& c) { return !c.neural.expand.empty(); }, no_value},
    {"--top-min",
     [](const BuildConfig& c) { return c.neural.top_min != defaults().neural.top_min; },
     [](const BuildConfig& c) { return double(c.neural.top_min); }},
    {"--greedy-top", [](const BuildConfig& c) { return c.neural.greedy_top; }, no_value},
};

// An option a structure reads and the values it takes.
struct Use {
  const char* name;
  double lo, hi;
};

constexpr double kCostMax = 1e6;
constexpr double kLeafMax = 1 << 20;

// What structure `accel` reads with builder `builder` (not empty).
std::vector<Use> uses(const std::string& accel, const std::string& builder,
                      const BuildConfig& config) {
  // Every structure reports its SAH cost with the constants, and builds with the thread limit.
  std::vector<Use> u = {
      {"--kt", 1e-6, kCostMax}, {"--ki", 1e-6, kCostMax}, {"--threads", 0, 1 << 16}};
  if (builder == "neural") {  // the inferred top, expanded by another builder of the structure
    u.insert(
        u.end(),
        {{"--model", 0, 0}, {"--expand", 0, 0}, {"--top-min", 0, 1 << 30}, {"--greedy-top", 0, 0}});
    const std::string& expand = config.neural.expand;
    if (expand == "neural") return u;  // refused by the neural builder itself
    const std::vector<Use> below =
        uses(accel, expand.empty() ? builder_names(accel).front() : expand, config);
    for (const Use& b : below)
      if (std::none_of(u.begin(), u.end(),
                       [&](const Use& x) { return std::strcmp(x.name, b.name) == 0; }))
        u.push_back(b);
    return u;
  }
  const Use depth{"--tree-depth", 0, 64}, leaf{"--leaf-size", 1, kLeafMax};
  if (accel == "kd") {
    u.insert(u.end(), {depth, leaf, {"--empty-bonus", 0, 1}});
    if (builder == "binned") u.push_back({"--bins", 2, 1 << 16});
  } else if (accel == "bvh") {
    u.insert(u.end(), {depth, leaf});
    if (builder == "binned" || builder == "sbvh") u.push_back({"--bins", 4, 256});
  } else if (accel == "bih") {
    u.insert(u.end(), {depth, leaf});
    if (builder == "sah") u.push_back({"--bins", 4, 256});
  }
  return u;  // brute and embree: nothing else
}

std::string resolved_builder(const std::string& accel, const BuildConfig& config) {
  return config.builder.empty() ? builder_names(accel).front() : config.builder;
}

std::string number(double v) {
  std::string s = std::to_string(v);
  s.erase(s.find_last_not_of('0') + 1);
  if (!s.empty() && s.back() == '.') s.pop_back();
  return s;
}

}  // namespace

void check_build_options(const std::string& accel, const BuildConfig& config) {
  for (const Use& use : uses(accel, resolved_builder(accel, config), config)) {
    const Field& field = *std::find_if(std::begin(kFields), std::end(kFields), [&](const Field& f) {
      return std::strcmp(f.name, use.name) == 0;
    });
    const double v = field.value(config);
    if (std::isnan(v) && field.value == no_value) continue;
    if (!(v >= use.lo && v <= use.hi))
      throw Error(use.name, "--accel " + accel + " takes " + number(use.lo) + " to " +
                                number(use.hi) + ", got " + number(v));
  }
}

std::vector<std::string> unused_options(const std::string& accel, const BuildConfig& config) {
  const std::vector<Use> read = uses(accel, resolved_builder(accel, config), config);
  std::vector<std::string> unused;
  for (const Field& field : kFields)
    if (field.set(config) && std::none_of(read.begin(), read.end(), [&](const Use& u) {
          return std::strcmp(u.name, field.name) == 0;
        }))
      unused.emplace_back(field.name);
  return unused;
}

}  // namespace splitray

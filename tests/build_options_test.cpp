// Build options (issue #25 item 4): one rule for every structure. A value outside the range a
// structure takes is an Error naming the option (never a silent clamp), on make_accel as on
// the command line; unused_options() lists what a structure ignores.
#include "splitray/accel/build_options.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "splitray/accel/accel.hpp"
#include "splitray/core/errors.hpp"

namespace splitray {
namespace {

const std::vector<Triangle> kOne = {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}};

// The message make_accel throws for `config`, or "" when it builds.
std::string build_error(const std::string& accel, const BuildConfig& config) {
  try {
    make_accel(accel, kOne, config);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

bool has(const std::vector<std::string>& names, const std::string& name) {
  return std::find(names.begin(), names.end(), name) != names.end();
}

TEST(BuildOptions, OutOfRangeValuesAreErrorsThatNameTheOption) {
  struct Case {
    std::string accel, builder;
    void (*set)(BuildConfig&);
    std::string expected;
  };
  const std::vector<Case> cases = {
      {"bvh", "binned", [](BuildConfig& c) { c.bins = 2; }, "--bins: --accel bvh takes 4 to 256"},
      {"bvh", "sbvh", [](BuildConfig& c) { c.bins = 257; }, "--bins: --accel bvh takes 4 to 256"},
      {"bih", "sah", [](BuildConfig& c) { c.bins = 3; }, "--bins: --accel bih takes 4 to 256"},
      {"kd", "binned", [](BuildConfig& c) { c.bins = 1; }, "--bins: --accel kd takes 2 to 65536"},
      {"kd", "", [](BuildConfig& c) { c.empty_bonus = 1.5f; }, "--empty-bonus"},
      {"kd", "", [](BuildConfig& c) { c.max_depth = 65; }, "--tree-depth"},
      {"bvh", "", [](BuildConfig& c) { c.max_leaf_prims = 0; }, "--leaf-size"},
      {"bih", "", [](BuildConfig& c) { c.traversal_cost = 0.0f; }, "--kt"},
      {"embree", "", [](BuildConfig& c) { c.intersection_cost = -1.0f; }, "--ki"},
      {"brute", "", [](BuildConfig& c) { c.threads = 1 << 20; }, "--threads"},
      {"kd", "neural", [](BuildConfig& c) { c.neural.top_min = -1; }, "--top-min"},
      // The neural builder checks the options of the builder that expands its top too.
      {"bvh", "neural",
       [](BuildConfig& c) {
         c.neural.expand = "binned";
         c.bins = 1000;
       },
       "--bins: --accel bvh takes 4 to 256"},
  };
  for (const Case& test : cases) {
    BuildConfig config;
    config.builder = test.builder;
    test.set(config);
    const std::string message = build_error(test.accel, config);
    EXPECT_NE(message.find(test.expected), std::string::npos)
        << test.accel << " " << test.builder << ": '" << message << "'";
  }
}

TEST(BuildOptions, ValuesAtTheEndsOfTheRangesBuild) {
  BuildConfig config;
  config.builder = "binned";
  config.bins = 4;
  EXPECT_EQ(build_error("bvh", config), "");
  config.bins = 256;
  EXPECT_EQ(build_error("bvh", config), "");
  config.bins = 2;
  EXPECT_EQ(build_error("kd", config), "");
  BuildConfig kd;
  kd.empty_bonus = 1;
  kd.max_depth = 64;
  kd.max_leaf_prims = 1;
  EXPECT_EQ(build_error("kd", kd), "");
  // Options a structure does not read are not range-checked: embree ignores --bins.
  BuildConfig embree;
  embree.bins = 1;
  EXPECT_EQ(build_error("embree", embree), "");
}

TEST(BuildOptions, UnusedOptionsAreTheOnesTheStructureIgnores) {
  BuildConfig defaults;
  for (const std::string& accel : accel_names())
    EXPECT_TRUE(unused_options(accel, defaults).empty()) << accel;

  BuildConfig config;
  config.bins = 32;
  config.empty_bonus = 0.5f;
  config.traversal_cost = 2;
  EXPECT_TRUE(has(unused_options("embree", config), "--bins"));
  EXPECT_TRUE(has(unused_options("bvh", config), "--empty-bonus"));
  EXPECT_FALSE(has(unused_options("kd", config), "--empty-bonus"));
  EXPECT_FALSE(has(unused_options("bvh", config), "--kt"));  // every SAH cost names K_T
  config.builder = "golden";                                 // kd's exact sweep: no bins
  EXPECT_TRUE(has(unused_options("kd", config), "--bins"));
  config.builder = "binned";
  EXPECT_FALSE(has(unused_options("kd", config), "--bins"));

  BuildConfig neural;
  neural.neural.greedy_top = true;
  neural.neural.top_min = 100;
  EXPECT_TRUE(has(unused_options("bvh", neural), "--greedy-top"));
  EXPECT_TRUE(has(unused_options("bvh", neural), "--top-min"));
  neural.builder = "neural";
  EXPECT_TRUE(unused_options("bvh", neural).empty());
}

}  // namespace
}  // namespace splitray

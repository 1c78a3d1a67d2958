// Bounding interval hierarchy: every builder's answers must be exactly brute's
// (hierarchy_oracle.hpp), the tree must not depend on the thread count, and the one-child
// nodes (the fifth traversal case) must be built where they pay without changing answers.
#include "splitray/accel/bih/bih.hpp"

#include <cstring>

#include "hierarchy_oracle.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray::test {
namespace {

const char* const kHorse = "horse/horse.obj.gz";
const std::vector<std::string> kBuilders = {"global", "median", "middle", "sah"};

void check_every_builder(const Reference& ref, const std::string& mesh) {
  for (const std::string& builder : kBuilders) {
    BuildConfig config;
    config.builder = builder;
    const auto accel = make_accel("bih", ref.tris, config);
    expect_same_answers(ref.brute, answers_of(*accel, ref.rays), ref.rays,
                        mesh + " bih " + builder);
  }
}

TEST(Bih, EveryBuilderMatchesBruteOnHorse) {
  check_every_builder(reference(vendored_file(kHorse)), "horse");
}

TEST(Bih, EveryBuilderMatchesBruteOnSibenik) {
  SPLITRAY_REQUIRE_SHARED(path, "static_sibenik/sibenik.obj");
  check_every_builder(reference(path, 20000), "sibenik");
}

TEST(Bih, EveryBuilderMatchesBruteOnLion) {
  SPLITRAY_REQUIRE_SHARED(path, "static_sumner_cat_lion_poses/lion-poses/lion-reference.obj.gz");
  check_every_builder(reference(path), "lion");
}

TEST(Bih, EveryBuilderMatchesBruteOnCornellBox) {  // axis-aligned walls: rays in their planes
  SPLITRAY_REQUIRE_SHARED(path, "static_cornell_box/cornell_box.obj");
  check_every_builder(reference(path, 20000), "cornell box");
}

std::vector<Triangle> grid_in_plane(int n) {
  std::vector<Triangle> tris;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const auto x0 = static_cast<float>(i), x1 = x0 + 1, y0 = static_cast<float>(j), y1 = y0 + 1;
      tris.push_back({{x0, y0, 2}, {x1, y0, 2}, {x1, y1, 2}});
      tris.push_back({{x0, y0, 2}, {x1, y1, 2}, {x0, y1, 2}});
    }
  return tris;
}

TEST(Bih, DegenerateInputsMatchBrute) {
  std::vector<std::pair<std::string, std::vector<Triangle>>> cases;
  cases.push_back({"one triangle", {{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}}});
  cases.push_back({"plane grid", grid_in_plane(24)});
  std::vector<Triangle> same(300, Triangle{{0, 0, 0}, {1, 0, 0}, {0, 1, 1}});  // coincident centres
  same.push_back({{5, 5, 5}, {6, 5, 5}, {5, 6, 5}});
  cases.push_back({"300 identical", same});
  std::vector<Triangle> clusters;  // two far-apart clusters: the grid halves its cells many times
  for (int i = 0; i < 40; ++i) {
    const float f = 1e-3f * static_cast<float>(i);
    clusters.push_back({{f, 0, 0}, {f + 1e-3f, 0, 0}, {f, 1e-3f, 0}});
    clusters.push_back(
        {{1000 + f, 1000, 1000}, {1000 + f + 1e-3f, 1000, 1000}, {1000 + f, 1000, 1000.001f}});
  }
  cases.push_back({"far clusters", clusters});
  for (const auto& [name, tris] : cases) {
    const std::vector<Ray> rays = hard_rays(tris, 4000, 7);
    const Answers brute = brute_answers(tris, rays);
    for (const std::string& builder : kBuilders) {
      BuildConfig config;
      config.builder = builder;
      const Answers got = answers_of(*make_accel("bih", tris, config), rays);
      for (std::size_t i = 0; i < rays.size(); ++i) {
        ASSERT_TRUE(same_hit(brute.hits[i], got.hits[i])) << name << " " << builder << " ray " << i;
        ASSERT_EQ(brute.occluded[i], got.occluded[i]) << name << " " << builder << " ray " << i;
      }
    }
  }
}

TEST(Bih, TreeAndHitsDoNotDependOnThreadCount) {
  const Reference& ref = reference(vendored_file(kHorse));
  for (const std::string& builder : kBuilders) {
    std::vector<Bih> trees;
    std::vector<Answers> answers;
    for (const int threads : {1, 2}) {
      ThreadLimit limit(threads);
      trees.push_back(
          Bih::build(ref.tris, BihBuildOptions::from({}, parse_bih_heuristic(builder))));
      answers.push_back(answers_of_structure(trees.back(), ref.rays));
    }
    const auto a = trees[0].nodes(), b = trees[1].nodes();
    ASSERT_EQ(a.size(), b.size()) << builder;
    EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size_bytes()), 0) << builder;
    expect_same_answers(answers[0], answers[1], ref.rays, "1 vs 2 threads " + builder);
  }
}

// The fifth case: one-child nodes appear where the SAH says so, and leaving them out (four
// cases only) gives the same answers.
TEST(Bih, OneChildNodesCutEmptySpaceWithoutChangingAnswers) {
  const Reference& ref = reference(vendored_file(kHorse));
  for (const std::string& builder : kBuilders) {
    BihBuildOptions options = BihBuildOptions::from({}, parse_bih_heuristic(builder));
    const Bih with = Bih::build(ref.tris, options);
    options.one_child_nodes = false;
    const Bih without = Bih::build(ref.tris, options);
    std::size_t one_child = 0, one_child_without = 0;
    for (const BihNode& n : with.nodes()) one_child += !n.leaf() && n.one_child() ? 1 : 0;
    for (const BihNode& n : without.nodes())
      one_child_without += !n.leaf() && n.one_child() ? 1 : 0;
    EXPECT_GT(one_child, 0u) << builder;
    EXPECT_EQ(one_child_without, 0u) << builder;
    AccelStats with_stats, without_stats;
    with.fill_stats(with_stats, 15, 20);
    without.fill_stats(without_stats, 15, 20);
    EXPECT_LT(*with_stats.sah_cost, *without_stats.sah_cost)
        << builder << ": cutting empty space must pay";
    expect_same_answers(ref.brute, answers_of_structure(without, ref.rays), ref.rays,
                        "four cases only " + builder);
  }
}

TEST(Bih, StatsDescribeTheTree) {
  const Reference& ref = reference(vendored_file(kHorse));
  std::map<std::string, AccelStats> stats;
  for (const std::string& builder : kBuilders) {
    BuildConfig config;
    config.builder = builder;
    const AccelStats s = make_accel("bih", ref.tris, config)->stats();
    EXPECT_EQ(s.accel, "bih");
    EXPECT_EQ(s.builder, builder);
    EXPECT_EQ(s.prims, ref.tris.size());
    EXPECT_EQ(s.prim_refs, ref.tris.size()) << builder << ": no primitive is referenced twice";
    EXPECT_GT(s.leaves, ref.tris.size() / 8) << builder;
    EXPECT_LT(s.nodes, 4 * ref.tris.size()) << builder;
    EXPECT_LE(s.max_depth, 64);
    EXPECT_GE(s.bytes, s.nodes * sizeof(BihNode));
    ASSERT_TRUE(s.sah_cost.has_value());
    EXPECT_GT(*s.sah_cost, 0);
    EXPECT_GT(s.build_ms, 0);
    stats[builder] = s;
  }
  EXPECT_EQ(sizeof(BihNode), 12u);
  EXPECT_GT(stats["sah"].cost_evals, 0u);
  for (const std::string builder : {"global", "median", "middle"})  // the SAH builder minimises it
    EXPECT_LT(*stats["sah"].sah_cost, *stats[builder].sah_cost) << builder;
}

TEST(Bih, LeafSizeIsHonoured) {
  const Reference& ref = reference(vendored_file(kHorse));
  BuildConfig config;
  config.builder = "global";
  config.max_leaf_prims = 4;
  const auto accel = make_accel("bih", ref.tris, config);
  const AccelStats& s = accel->stats();
  EXPECT_GT(s.mean_leaf_prims, 1.5);
  EXPECT_LE(s.mean_leaf_prims, 4.0);
  expect_same_answers(ref.brute, answers_of(*accel, ref.rays), ref.rays, "global, leaves of 4");
}

TEST(Bih, UnknownBuilderIsAnError) {
  const Reference& ref = reference(vendored_file(kHorse));
  BuildConfig config;
  config.builder = "octree";
  EXPECT_THROW(make_accel("bih", ref.tris, config), Error);
  EXPECT_THROW(parse_bih_heuristic("octree"), Error);
}

}  // namespace
}  // namespace splitray::test

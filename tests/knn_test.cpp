// Nearest-neighbour search (issue 6): every point kd-tree builder answers exactly like brute
// force (indices and distances, ties to the smaller index) for k = 1, 8, 50 and radius search
// on real surface samples with duplicate points and queries exactly on points; nanoflann and
// FLANN agree in distances; results never depend on the thread count; bad input is an Error.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <set>

#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/random.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/query/brute_force.hpp"
#include "splitray/query/neighbor_index.hpp"
#include "splitray/query/point_input.hpp"
#include "splitray/query/point_io.hpp"
#include "splitray/query/point_tree.hpp"
#include "splitray/query/surface_sampling.hpp"
#include "test_data.hpp"

namespace splitray {
namespace {

const std::vector<std::string> kOurBuilders = {"vvh", "sah", "median"};

// Surface samples of a mesh with duplicates (single copies and a cluster larger than a leaf),
// and queries: other surface samples, exact copies of points, and a few far outside.
struct PointSet {
  std::vector<Vec3> points, queries;
  float diagonal = 0;
};

PointSet make_point_set(const Mesh& mesh, std::size_t count, std::size_t query_count) {
  PointSet set;
  set.points = sample_surface(mesh, count, 7, kPointStream);
  const std::size_t base = set.points.size();
  for (std::size_t i = 0; i < base; i += 97) set.points.push_back(set.points[i]);
  for (int copy = 0; copy < 40; ++copy) set.points.push_back(set.points[base / 2]);
  set.queries = sample_surface(mesh, query_count, 7, kQueryStream);
  for (std::size_t i = 0; i < set.points.size(); i += set.points.size() / 150)
    set.queries.push_back(set.points[i]);
  set.queries.push_back(set.points[base / 2]);  // on the 41-fold point (cluster)
  Aabb box;
  for (const Vec3& p : set.points) box.extend(p);
  set.diagonal = length(box.extent());
  set.queries.push_back(box.hi + box.extent());  // far outside, above
  set.queries.push_back(box.lo - Vec3(0.1f * set.diagonal, 0, 0));
  return set;
}

const PointSet& horse_points() {
  static const PointSet set =
      make_point_set(load_mesh(test::vendored_file("horse/horse.obj.gz")), 20000, 1500);
  return set;
}

void expect_same_knn(const KnnResult& expected, const KnnResult& actual, const std::string& what) {
  ASSERT_EQ(expected.queries, actual.queries) << what;
  ASSERT_EQ(expected.k, actual.k) << what;
  std::size_t mismatches = 0;
  for (std::size_t i = 0; i < expected.indices.size(); ++i)
    if (expected.indices[i] != actual.indices[i] || expected.distances[i] != actual.distances[i]) {
      if (++mismatches <= 3)
        ADD_FAILURE() << what << ": query " << i / expected.k << " rank " << i % expected.k
                      << ": expected " << expected.indices[i] << " at " << expected.distances[i]
                      << ", got " << actual.indices[i] << " at " << actual.distances[i];
    }
  EXPECT_EQ(mismatches, 0u) << what;
}

void expect_same_radius(const RadiusResult& expected, const RadiusResult& actual,
                        const std::string& what) {
  ASSERT_EQ(expected.queries(), actual.queries()) << what;
  EXPECT_EQ(expected.offsets, actual.offsets) << what;
  EXPECT_EQ(expected.indices, actual.indices) << what;
  EXPECT_EQ(expected.distances, actual.distances) << what;
}

// Distances agree rank by rank (other libraries may order tied indices differently).
void expect_same_distances(const KnnResult& expected, const KnnResult& actual,
                           const std::string& what) {
  ASSERT_EQ(expected.distances.size(), actual.distances.size()) << what;
  std::size_t mismatches = 0;
  for (std::size_t i = 0; i < expected.distances.size(); ++i)
    if (expected.distances[i] != actual.distances[i] && ++mismatches <= 3)
      ADD_FAILURE() << what << ": query " << i / expected.k << " rank " << i % expected.k << ": "
                    << expected.distances[i] << " vs " << actual.distances[i];
  EXPECT_EQ(mismatches, 0u) << what;
  EXPECT_EQ(summarize(expected).dist_sum, summarize(actual).dist_sum) << what;
}

TEST(KnnTest, EveryBuilderEqualsBruteForceForKNearest) {
  const PointSet& set = horse_points();
  for (int k : {1, 8, 50}) {
    const KnnResult expected = brute_force_knn(set.points, set.queries, k);
    for (const std::string& builder : kOurBuilders) {
      for (int leaf_size : {1, 12}) {
        const PointTree tree(set.points, {.builder = builder, .leaf_size = leaf_size});
        expect_same_knn(expected, tree.knn(set.queries, k),
                        builder + " leaf " + std::to_string(leaf_size) + " k=" + std::to_string(k));
      }
    }
  }
}

TEST(KnnTest, EveryBuilderEqualsBruteForceForRadius) {
  const PointSet& set = horse_points();
  for (float fraction : {0.0f, 0.003f, 0.02f}) {
    const float r = fraction * set.diagonal;
    const RadiusResult expected = brute_force_radius(set.points, set.queries, r);
    if (fraction == 0) {
      EXPECT_GE(expected.indices.size(), 150u + 41u);  // queries on points find them
    } else if (fraction > 0.01f) {
      EXPECT_GT(expected.indices.size(), 10 * set.queries.size());
    }
    for (const std::string& builder : kOurBuilders) {
      const PointTree tree(set.points, {.builder = builder, .radius = r});
      expect_same_radius(expected, tree.radius(set.queries, r),
                         builder + " r=" + std::to_string(r));
    }
  }
}

TEST(KnnTest, TiesGoToTheSmallerIndex) {
  const PointSet& set = horse_points();
  const Vec3 cluster = set.points[20000 / 2];  // 41 copies: the original and 40 duplicates
  const PointTree tree(set.points, {.builder = "vvh", .leaf_size = 4});
  std::vector<std::uint32_t> indices(50);
  std::vector<float> distances(50);
  tree.knn(cluster, 50, indices, distances);
  std::vector<std::uint32_t> copies;
  for (std::size_t i = 0; i < set.points.size(); ++i)
    if (set.points[i] == cluster) copies.push_back(static_cast<std::uint32_t>(i));
  ASSERT_GE(copies.size(), 41u);
  for (std::size_t j = 0; j < copies.size(); ++j) {
    EXPECT_EQ(indices[j], copies[j]) << "rank " << j;
    EXPECT_EQ(distances[j], 0.0f);
  }
  EXPECT_GT(distances[copies.size()], 0.0f);
}

TEST(KnnTest, SingleQueriesMatchTheBatch) {
  const PointSet& set = horse_points();
  const PointTree tree(set.points, {.builder = "vvh"});
  const KnnResult batch = tree.knn(set.queries, 8);
  const float r = 0.01f * set.diagonal;
  const RadiusResult radius_batch = tree.radius(set.queries, r);
  for (std::size_t q = 0; q < set.queries.size(); q += 37) {
    std::vector<std::uint32_t> indices(8);
    std::vector<float> distances(8);
    EXPECT_EQ(tree.knn(set.queries[q], 8, indices, distances), 8);
    EXPECT_TRUE(std::ranges::equal(indices, batch.indices_of(q))) << "query " << q;
    EXPECT_TRUE(std::ranges::equal(distances, batch.distances_of(q))) << "query " << q;
    std::vector<std::uint32_t> within;
    std::vector<float> within_distances;
    tree.radius(set.queries[q], r, within, within_distances);
    EXPECT_TRUE(std::ranges::equal(within, radius_batch.indices_of(q))) << "query " << q;
    EXPECT_TRUE(std::ranges::equal(within_distances, radius_batch.distances_of(q)))
        << "query " << q;
  }
}

TEST(KnnTest, NanoflannAndFlannEqualBruteForceInDistances) {
  const PointSet& set = horse_points();
  const std::vector<int> ks = {1, 8, 50};
  const std::vector<float> radii = {0.0f, 0.01f * set.diagonal};
  std::vector<KnnResult> knn;
  std::vector<RadiusResult> within;
  knn.reserve(ks.size());
  within.reserve(radii.size());
  for (int k : ks) knn.push_back(brute_force_knn(set.points, set.queries, k));
  for (float r : radii) within.push_back(brute_force_radius(set.points, set.queries, r));
  for (const std::string name : {"nanoflann", "flann"}) {
    for (bool coherent : {false, true}) {
      const auto index =
          make_neighbor_index(set.points, {.builder = name, .coherent_peers = coherent});
      for (std::size_t i = 0; i < ks.size(); ++i)
        expect_same_distances(knn[i], index->knn(set.queries, ks[i]),
                              name + " k=" + std::to_string(ks[i]));
      for (std::size_t i = 0; i < radii.size(); ++i) {
        const RadiusResult& expected = within[i];
        const RadiusResult actual = index->radius(set.queries, radii[i]);
        EXPECT_EQ(expected.offsets, actual.offsets) << name << " r=" << radii[i];
        EXPECT_EQ(expected.distances, actual.distances) << name << " r=" << radii[i];
        // Ties aside, the same points: the index sets agree per query.
        for (std::size_t q = 0; q < expected.queries(); ++q) {
          const auto e = expected.indices_of(q), a = actual.indices_of(q);
          ASSERT_EQ(std::set<std::uint32_t>(e.begin(), e.end()),
                    std::set<std::uint32_t>(a.begin(), a.end()))
              << name << " query " << q;
        }
      }
    }
  }
}

TEST(KnnTest, TheFactoryBuildsEveryNameAndTheyAgree) {
  const PointSet& set = horse_points();
  const std::span<const Vec3> queries(set.queries.data(), 300);
  const NeighborSummary expected = summarize(brute_force_knn(set.points, queries, 8));
  for (const std::string& name : neighbor_index_names()) {
    const auto index = make_neighbor_index(set.points, {.builder = name});
    EXPECT_EQ(index->name(), name);
    EXPECT_EQ(index->points(), set.points.size());
    EXPECT_GE(index->build_ms(), 0.0);
    const NeighborSummary actual = summarize(index->knn(queries, 8));
    EXPECT_EQ(actual.dist_sum, expected.dist_sum) << name;
    if (name != "nanoflann" && name != "flann") {
      EXPECT_EQ(actual.checksum, expected.checksum) << name;
    }
  }
}

TEST(KnnTest, ResultsAndTreesDoNotDependOnTheThreadCount) {
  const PointSet& set = horse_points();
  for (const std::string& builder : kOurBuilders) {
    std::vector<PointNode> nodes[2];
    std::vector<std::uint32_t> permutation[2];
    KnnResult knn[2];
    RadiusResult radius[2];
    for (int t = 0; t < 2; ++t) {
      const ThreadLimit limit(t + 1);
      const PointTree tree(set.points, {.builder = builder, .leaf_size = 6});
      nodes[t].assign(tree.nodes().begin(), tree.nodes().end());
      permutation[t].assign(tree.permutation().begin(), tree.permutation().end());
      knn[t] = tree.knn(set.queries, 8);
      radius[t] = tree.radius(set.queries, 0.01f * set.diagonal);
    }
    ASSERT_EQ(nodes[0].size(), nodes[1].size()) << builder;
    EXPECT_EQ(0, std::memcmp(nodes[0].data(), nodes[1].data(), nodes[0].size() * sizeof(PointNode)))
        << builder;
    EXPECT_EQ(permutation[0], permutation[1]) << builder;
    expect_same_knn(knn[0], knn[1], builder + " 1 vs 2 threads");
    expect_same_radius(radius[0], radius[1], builder + " 1 vs 2 threads");
  }
}

// The tree is what the header promises: a permutation, planes that separate the children
// with a gap, leaves within the leaf size (or identical points), depth within the stack.
TEST(KnnTest, TreesAreWellFormed) {
  const PointSet& set = horse_points();
  for (const std::string& builder : kOurBuilders) {
    const PointTree tree(set.points, {.builder = builder, .leaf_size = 8});
    std::vector<std::uint32_t> sorted(tree.permutation().begin(), tree.permutation().end());
    std::ranges::sort(sorted);
    for (std::size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], i) << builder;
    const auto nodes = tree.nodes();
    const auto perm = tree.permutation();
    // Walk with the range of points under each node.
    struct Entry {
      std::uint32_t node;
      Aabb cell;
      int depth;
    };
    std::vector<Entry> stack{{0, tree.bounds(), 0}};
    std::size_t covered = 0;
    while (!stack.empty()) {
      const Entry e = stack.back();
      stack.pop_back();
      ASSERT_LT(e.depth, PointTree::kMaxDepth) << builder;
      const PointNode& node = nodes[e.node];
      if (node.is_leaf()) {
        covered += node.count();
        bool identical = true;
        for (std::uint32_t i = 0; i < node.count(); ++i) {
          const Vec3& p = set.points[perm[node.index + i]];
          EXPECT_TRUE(e.cell.contains(p)) << builder << " leaf " << e.node;
          identical = identical && p == set.points[perm[node.index]];
        }
        EXPECT_TRUE(node.count() <= 8 || identical || builder != "median")
            << builder << " leaf of " << node.count();
        EXPECT_LE(node.count(), 1024u) << builder;
        continue;
      }
      EXPECT_LT(node.below_max, node.above_min) << builder;
      Aabb below = e.cell, above = e.cell;
      below.hi[node.axis()] = node.below_max;
      above.lo[node.axis()] = node.above_min;
      stack.push_back({e.node + 1, below, e.depth + 1});
      stack.push_back({e.node + node.index, above, e.depth + 1});
    }
    EXPECT_EQ(covered, set.points.size()) << builder;
    const PointTreeStats stats = tree.stats();
    EXPECT_EQ(stats.nodes, nodes.size());
    EXPECT_GT(stats.vvh_cost, 0);
    EXPECT_EQ(stats.builder, builder);
  }
}

TEST(KnnTest, VvhTreesCostLessThanMedianTrees) {
  const PointSet& set = horse_points();
  const double vvh = PointTree(set.points, {.builder = "vvh"}).stats().vvh_cost;
  const double median = PointTree(set.points, {.builder = "median"}).stats().vvh_cost;
  EXPECT_LT(vvh, median);
}

TEST(KnnTest, PointInLeafFindsThePointsOwnLeaf) {
  const PointSet& set = horse_points();
  for (const std::string& builder : kOurBuilders) {
    const PointTree tree(set.points, {.builder = builder});
    const std::vector<std::uint32_t> populations = tree.leaf_populations(set.points);
    for (std::size_t i = 0; i < set.points.size(); i += 13) {
      const auto leaf = tree.leaf_points(set.points[i]);
      EXPECT_EQ(leaf.size(), populations[i]);
      // The point itself, or an identical one (duplicates share a leaf).
      EXPECT_TRUE(std::ranges::any_of(
          leaf, [&](std::uint32_t j) { return set.points[j] == set.points[i]; }))
          << builder << " point " << i;
    }
  }
}

TEST(KnnTest, DegenerateInputs) {
  std::vector<Vec3> same(300, Vec3(1, 2, 3));
  std::vector<Vec3> one{Vec3(5, 5, 5)};
  std::vector<Vec3> plane, line;
  for (int i = 0; i < 40; ++i)
    for (int j = 0; j < 40; ++j) plane.push_back({static_cast<float>(i), static_cast<float>(j), 0});
  for (int i = 0; i < 500; ++i) line.push_back({0, static_cast<float>(i % 250) * 0.5f, 0});
  // Far apart: distances² near and beyond the float range (the farthest are infinite).
  std::vector<Vec3> huge;
  Pcg32 rng(5);
  for (int i = 0; i < 400; ++i) {
    const float scale = i % 2 ? 1e18f : 3e19f;
    huge.push_back(Vec3(rng.next_float() - 0.5f, rng.next_float() - 0.5f, rng.next_float()) *
                   scale);
  }
  const std::vector<Vec3> queries{Vec3(1, 2, 3),    Vec3(0, 0, 0), Vec3(10.5f, 3.25f, 1),
                                  Vec3(-5, 100, 2), huge[7],       Vec3(1e19f, -2e19f, 5e18f)};
  for (const std::vector<Vec3>* points : {&same, &one, &plane, &line, &huge}) {
    for (const std::string& builder : kOurBuilders) {
      const PointTree tree(*points, {.builder = builder, .leaf_size = 2});
      const int k = std::min<int>(5, static_cast<int>(points->size()));
      expect_same_knn(brute_force_knn(*points, queries, k), tree.knn(queries, k), builder);
      expect_same_radius(brute_force_radius(*points, queries, 3), tree.radius(queries, 3), builder);
    }
  }
}

TEST(KnnTest, NoQueriesGiveEmptyResults) {
  const PointSet& set = horse_points();
  for (const std::string& name : neighbor_index_names()) {
    const auto index = make_neighbor_index(set.points, {.builder = name});
    const KnnResult knn = index->knn({}, 3);
    EXPECT_EQ(knn.queries, 0u) << name;
    EXPECT_TRUE(knn.indices.empty()) << name;
    const RadiusResult within = index->radius({}, 1);
    EXPECT_EQ(within.queries(), 0u) << name;
    EXPECT_TRUE(within.indices.empty()) << name;
  }
}

TEST(KnnTest, BadInputIsAClearError) {
  const std::vector<Vec3> empty;
  const std::vector<Vec3> points{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  const std::vector<Vec3> queries{Vec3(0, 0, 0)};
  const auto message = [](const auto& f) {
    try {
      f();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message([&] { PointTree tree(empty); }).find("no points"), std::string::npos);
  for (const std::string& name : neighbor_index_names())
    EXPECT_NE(message([&] { make_neighbor_index(empty, {.builder = name}); }).find("no points"),
              std::string::npos)
        << name;
  const PointTree tree(points);
  EXPECT_NE(message([&] { tree.knn(queries, 4); }).find("k = 4 exceeds the number of points (3)"),
            std::string::npos);
  EXPECT_NE(message([&] { tree.knn(queries, 0); }).find("at least 1"), std::string::npos);
  for (const std::string& name : neighbor_index_names())
    EXPECT_NE(message([&] {
                make_neighbor_index(points, {.builder = name})->knn(queries, 4);
              }).find("exceeds the number of points"),
              std::string::npos)
        << name;
  EXPECT_NE(message([&] { tree.radius(queries, -1.0f); }).find("radius"), std::string::npos);
  EXPECT_NE(message([&] {
              tree.radius(queries, std::numeric_limits<float>::quiet_NaN());
            }).find("radius"),
            std::string::npos);
  const std::vector<Vec3> nan_point{Vec3(0, 0, 0),
                                    Vec3(std::numeric_limits<float>::quiet_NaN(), 0, 0)};
  EXPECT_NE(message([&] { PointTree t(nan_point); }).find("point 1"), std::string::npos);
  EXPECT_NE(message([&] { PointTree t(points, {.builder = "octree"}); }).find("octree"),
            std::string::npos);
  EXPECT_NE(message([&] { make_neighbor_index(points, {.builder = "octree"}); }).find("octree"),
            std::string::npos);
  EXPECT_NE(message([&] { PointTree t(points, {.leaf_size = 0}); }).find("leaf size"),
            std::string::npos);
  const std::vector<Vec3> bad_queries{Vec3(0, 0, 0),
                                      Vec3(0, std::numeric_limits<float>::infinity(), 0)};
  for (const std::string& name : neighbor_index_names()) {
    const auto index = make_neighbor_index(points, {.builder = name});
    EXPECT_NE(message([&] { index->knn(bad_queries, 1); }).find("query 1"), std::string::npos)
        << name;
    EXPECT_NE(message([&] { index->radius(bad_queries, 1); }).find("query 1"), std::string::npos)
        << name;
  }
}

TEST(KnnTest, SurfaceSamplesAreReproducibleAndOnTheSurface) {
  const Mesh mesh = load_mesh(test::vendored_file("horse/horse.obj.gz"));
  std::vector<Vec3> a, b;
  {
    const ThreadLimit limit(1);
    a = sample_surface(mesh, 150000, 3);
  }
  {
    const ThreadLimit limit(2);
    b = sample_surface(mesh, 150000, 3);
  }
  EXPECT_EQ(a, b);
  EXPECT_NE(a, sample_surface(mesh, 150000, 4));
  EXPECT_NE(a, sample_surface(mesh, 150000, 3, kQueryStream));
  const Aabb box = mesh.bounds();
  for (const Vec3& p : a) ASSERT_TRUE(box.contains(p));
  // Area weighting: the share of samples on the larger half of the area is about half.
  Mesh flat;
  flat.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {10, 0, 0}, {13, 0, 0}, {10, 1, 0}};
  flat.faces = {{0, 1, 2}, {3, 4, 5}};  // areas 0.5 and 1.5
  const std::vector<Vec3> samples = sample_surface(flat, 40000, 1);
  const auto on_big = std::ranges::count_if(samples, [](const Vec3& p) { return p.x >= 10; });
  EXPECT_NEAR(static_cast<double>(on_big) / 40000, 0.75, 0.01);
  Mesh degenerate;
  degenerate.positions = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}};
  degenerate.faces = {{0, 1, 2}};
  EXPECT_THROW(sample_surface(degenerate, 10, 1), Error);
}

TEST(KnnTest, RealSharedMeshEqualsBruteForce) {
  SPLITRAY_REQUIRE_SHARED(path, "static_sumner_cat_lion_poses/cat-poses/cat-reference.obj.gz");
  const PointSet set = make_point_set(load_mesh(path), 60000, 800);
  for (const std::string& builder : kOurBuilders) {
    const PointTree tree(set.points, {.builder = builder});
    for (int k : {1, 8, 50})
      expect_same_knn(brute_force_knn(set.points, set.queries, k), tree.knn(set.queries, k),
                      builder + " k=" + std::to_string(k));
    const float r = 0.01f * set.diagonal;
    expect_same_radius(brute_force_radius(set.points, set.queries, r), tree.radius(set.queries, r),
                       builder);
  }
}

// ---- point files --------------------------------------------------------------------------

void write_bytes(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

template <typename T>
void append(std::string& bytes, T value, bool big_endian = false) {
  char raw[sizeof(T)];
  std::memcpy(raw, &value, sizeof(T));
  if (big_endian) std::reverse(raw, raw + sizeof(T));
  bytes.append(raw, sizeof(T));
}

std::string error_of(const std::string& path) {
  try {
    load_points(path);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

TEST(KnnTest, PointFilesLoad) {
  const auto dir = test::temp_dir("knn_points");
  const std::vector<Vec3> expected{{1, 2, 3}, {-4.5f, 0.25f, 1e-3f}, {7, 8, 9}};
  write_bytes(dir / "a.xyz", "# comment\n1 2 3\n\n  -4.5\t0.25 1e-3 0.9 0.1 0.2\r\n+7 8 9");
  EXPECT_EQ(load_points((dir / "a.xyz").string()), expected);
  EXPECT_TRUE(is_point_file((dir / "a.xyz").string()));

  write_bytes(
      dir / "ascii.ply",
      "ply\nformat ascii 1.0\ncomment hi\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nproperty uchar red\nend_header\n1 2 3 255\n-4.5 0.25 1e-3 0\n7 8 9 1\n");
  EXPECT_EQ(load_points((dir / "ascii.ply").string()), expected);
  EXPECT_TRUE(is_point_file((dir / "ascii.ply").string()));

  for (bool big : {false, true}) {
    // An element before the vertices (with a list) and doubles in y order z, y, x.
    std::string bytes =
        std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") +
        " 1.0\nelement camera 1\nproperty list uchar int ids\nelement vertex 3\n"
        "property double z\nproperty int tag\nproperty double y\nproperty double x\n"
        "element face 0\nproperty list uchar int vertex_indices\nend_header\n";
    append<std::uint8_t>(bytes, 2, big);
    append<std::int32_t>(bytes, 11, big);
    append<std::int32_t>(bytes, 12, big);
    for (const Vec3& p : expected) {
      append<double>(bytes, p.z, big);
      append<std::int32_t>(bytes, -1, big);
      append<double>(bytes, p.y, big);
      append<double>(bytes, p.x, big);
    }
    write_bytes(dir / "binary.ply", bytes);
    EXPECT_EQ(load_points((dir / "binary.ply").string()), expected) << (big ? "big" : "little");
    EXPECT_TRUE(is_point_file((dir / "binary.ply").string()));
  }

  write_bytes(
      dir / "mesh.ply",
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
      "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_FALSE(is_point_file((dir / "mesh.ply").string()));  // a mesh: sampled, not read as points
  const PointInput input = load_point_input((dir / "mesh.ply").string(), 500, 1);
  EXPECT_TRUE(input.mesh.has_value());
  EXPECT_EQ(input.points.size(), 500u);
  const PointInput points_input = load_point_input((dir / "a.xyz").string(), 500, 1);
  EXPECT_FALSE(points_input.mesh.has_value());
  EXPECT_EQ(points_input.points, expected);
  EXPECT_EQ(make_queries(points_input, 10, 1), make_queries(points_input, 10, 1));
  EXPECT_EQ(make_queries(input, 10, 1), make_queries(input, 10, 1));
}

TEST(KnnTest, BrokenPointFilesAreClearErrors) {
  const auto dir = test::temp_dir("knn_bad_points");
  const auto check = [&](const std::string& name, const std::string& bytes,
                         const std::string& expected) {
    const std::string path = (dir / name).string();
    write_bytes(path, bytes);
    const std::string message = error_of(path);
    EXPECT_NE(message.find(path), std::string::npos) << message;
    EXPECT_NE(message.find(expected), std::string::npos) << name << ": " << message;
  };
  EXPECT_NE(error_of((dir / "missing.xyz").string()).find("no such file"), std::string::npos);
  check("empty.xyz", "", "the file is empty");  // io/read_file, as for every input
  check("comments.xyz", "# only\n\n", "no points");
  check("two.xyz", "1 2 3\n4 5\n", "line 2");
  check("word.xyz", "1 2 3\n4 five 6\n", "line 2");
  check("glued.xyz", "1 2 3x\n", "line 1");
  check("nan.xyz", "1 2 3\nnan 0 0\n", "NaN");
  check("inf.xyz", "1 2 3\n0 inf 0\n", "NaN or infinite");
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n";
  check("huge.ply", header + std::string(24, '\0'), "more than the file holds");
  check(
      "truncated.ply",
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
      "property float z\nend_header\n" +
          std::string(20, '\0'),
      "more than the file holds");
  check("no_magic.ply", "plx\n", "not a PLY file");
  check("header_only.ply",  // no newline after end_header, no body
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty "
        "float z\n"
        "end_header",
        "ends inside element 'vertex'");
  check("no_end.ply", "ply\nformat ascii 1.0\nelement vertex 1\n", "end_header");
  check("no_x.ply",
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float y\nproperty float "
        "z\nend_header\n1 2\n",
        "lacks an x, y or z");
  check("bad_type.ply", "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n",
        "unknown property type");
  check("bad_format.ply", "ply\nformat ebcdic 1.0\nend_header\n", "unknown format");
  check("short_ascii.ply",
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty "
        "float z\n"
        "end_header\n1 2 3\n",
        "ends inside element 'vertex'");
  check("bad_number.ply",
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty "
        "float z\n"
        "end_header\n1 two 3\n",
        "expected a number");
  check("nan.ply",
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty "
        "float z\n"
        "end_header\n1 nan 3\n",
        "NaN");
  check("negative_count.ply", "ply\nformat ascii 1.0\nelement vertex -3\nend_header\n",
        "non-negative count");
  std::string list_bomb =
      "ply\nformat binary_little_endian 1.0\nelement face 1\nproperty list uint int idx\nelement "
      "vertex 1\n"
      "property float x\nproperty float y\nproperty float z\nend_header\n";
  append<std::uint32_t>(list_bomb, 4000000000u);
  check("list_bomb.ply", list_bomb, "ends inside element 'face'");
}

}  // namespace
}  // namespace splitray

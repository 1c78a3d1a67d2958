// The neural builder's inference side (paper 003 §4.1, §4.3-4.5): the model file format and
// its strict reader, the plain C++ forward pass against a hand-computed network, and trees
// whose top is inferred by a model (small random weights, written and read back through the
// file format) answering exactly like brute force: kd-trees, BVHs and point kd-trees.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>

#include "hierarchy_oracle.hpp"
#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/accel/neural/model_path.hpp"
#include "splitray/accel/neural/neural_accel.hpp"
#include "splitray/accel/neural/neural_model.hpp"
#include "splitray/accel/neural/neural_sampling.hpp"
#include "splitray/accel/neural/neural_top.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/query/brute_force.hpp"
#include "splitray/query/neural_point_build.hpp"
#include "splitray/query/point_build.hpp"
#include "splitray/query/point_tree.hpp"
#include "splitray/query/surface_sampling.hpp"

namespace splitray::test {
namespace {

DenseLayer random_layer(int in, int out, int activation, Pcg32& rng, float scale, float bias) {
  DenseLayer l;
  l.in = in;
  l.out = out;
  l.activation = activation;
  for (int i = 0; i < in * out; ++i) l.weight.push_back(scale * (2 * rng.next_float() - 1));
  for (int o = 0; o < out; ++o) l.bias.push_back(bias + 0.1f * (2 * rng.next_float() - 1));
  return l;
}

// Per level 1 -> 8 -> 8 per point, 8 -> 8 -> 1 head; the head's bias keeps λ' near 0.5 with
// the points' influence in the weights, so that splits vary between nodes and levels.
NeuralModel random_model(NeuralCost cost, int depth, NeuralPooling pooling, std::uint64_t seed) {
  Pcg32 rng(seed);
  NeuralModel m;
  m.cost = cost;
  m.points = 1024;
  m.pooling = pooling;
  for (int d = 0; d < depth; ++d) {
    LevelEncoder e;
    e.point_layers.push_back(random_layer(1, 8, 1, rng, 1.0f, 0.0f));
    e.point_layers.push_back(random_layer(8, 8, 1, rng, 0.5f, 0.0f));
    e.head_layers.push_back(random_layer(8, 8, 1, rng, 0.5f, 0.0f));
    e.head_layers.push_back(random_layer(8, 1, 0, rng, 0.2f, 0.5f));
    m.levels.push_back(std::move(e));
  }
  m.metadata = R"({"test": true})";
  return m;
}

// Written through the file format and read back, as a shipped model would be.
std::string model_file(NeuralCost cost, int depth) {
  const std::string name = cost == NeuralCost::sah ? "sah" : "vvh";
  const std::string path = (temp_dir("neural-model-" + name) / (name + ".bin")).string();
  write_neural_model(random_model(cost, depth, NeuralPooling::max, 42), path);
  return path;
}

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

void expect_read_error(const std::string& path, const std::string& what) {
  try {
    (void)read_neural_model(path);
    ADD_FAILURE() << what << ": read without error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << what << ": " << e.what();
  }
}

TEST(NeuralModel, RoundTripsThroughTheFile) {
  const NeuralModel m = random_model(NeuralCost::vvh, 3, NeuralPooling::mean, 7);
  const std::filesystem::path dir = temp_dir("neural-roundtrip");
  const std::string path = (dir / "m.bin").string();
  write_neural_model(m, path);
  write_neural_model(m, path);  // over an existing file
  const NeuralModel r = read_neural_model(path);
  EXPECT_EQ(r.cost, NeuralCost::vvh);
  EXPECT_EQ(r.points, m.points);
  EXPECT_EQ(r.pooling, NeuralPooling::mean);
  EXPECT_EQ(r.metadata, m.metadata);
  ASSERT_EQ(r.depth(), 3);
  for (int d = 0; d < 3; ++d) {
    const auto& a = m.levels[static_cast<std::size_t>(d)];
    const auto& b = r.levels[static_cast<std::size_t>(d)];
    ASSERT_EQ(a.point_layers.size(), b.point_layers.size());
    ASSERT_EQ(a.head_layers.size(), b.head_layers.size());
    for (std::size_t i = 0; i < a.point_layers.size(); ++i) {
      EXPECT_EQ(a.point_layers[i].weight, b.point_layers[i].weight);
      EXPECT_EQ(a.point_layers[i].bias, b.point_layers[i].bias);
      EXPECT_EQ(a.point_layers[i].activation, b.point_layers[i].activation);
    }
    for (std::size_t i = 0; i < a.head_layers.size(); ++i)
      EXPECT_EQ(a.head_layers[i].weight, b.head_layers[i].weight);
  }
  // The atomic write leaves no temporary file behind.
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1u);
}

TEST(NeuralModel, CorruptAndTruncatedFilesAreRejectedNamingTheFile) {
  const std::string dir = temp_dir("neural-corrupt").string();
  const std::string good = dir + "/good.bin";
  write_neural_model(random_model(NeuralCost::sah, 2, NeuralPooling::max, 3), good);
  const std::string bytes = read_bytes(good);
  ASSERT_NO_THROW((void)read_neural_model(good));

  const std::string bad = dir + "/bad.bin";
  // Every truncation, byte by byte near the ends and in steps in between.
  for (std::size_t n = 0; n < bytes.size(); n += (n < 64 || n + 64 > bytes.size()) ? 1 : 37) {
    write_bytes(bad, bytes.substr(0, n));
    expect_read_error(bad, "truncated to " + std::to_string(n));
  }
  write_bytes(bad, bytes + "x");
  expect_read_error(bad, "trailing byte");
  std::string magic = bytes;
  magic[15] = '2';
  write_bytes(bad, magic);
  expect_read_error(bad, "wrong magic");

  const auto patch_u32 = [&](std::size_t offset, std::uint32_t value) {
    std::string b = bytes;
    std::memcpy(b.data() + offset, &value, 4);
    write_bytes(bad, b);
  };
  // Header: magic(16) cost depth points pooling; level 0: point layer count, in, out, act.
  patch_u32(16, 2);
  expect_read_error(bad, "unknown cost");
  patch_u32(20, 0);
  expect_read_error(bad, "depth 0");
  patch_u32(20, 5000);
  expect_read_error(bad, "depth over the limit");
  patch_u32(32, 5000);
  expect_read_error(bad, "layer count over 4096");
  patch_u32(36, 2);
  expect_read_error(bad, "first point layer in != 1");
  patch_u32(44, 7);
  expect_read_error(bad, "unknown activation");
  patch_u32(48, 0x7fc00000u);  // the first weight: NaN
  expect_read_error(bad, "NaN weight");
  patch_u32(48, 0x7f800000u);
  expect_read_error(bad, "infinite weight");
  expect_read_error(dir + "/missing.bin", "missing file");

  // The writer refuses models the reader would refuse.
  NeuralModel broken = random_model(NeuralCost::sah, 1, NeuralPooling::max, 3);
  broken.levels[0].head_layers.back().out = 2;
  EXPECT_THROW(write_neural_model(broken, dir + "/broken.bin"), Error);
  broken = random_model(NeuralCost::sah, 1, NeuralPooling::max, 3);
  broken.levels[0].point_layers[1].in = 3;
  EXPECT_THROW(write_neural_model(broken, dir + "/broken.bin"), Error);
}

TEST(NeuralModel, EncodeAxisEqualsAHandComputedNetwork) {
  // Per point: relu([1, -1] x + [0, 3]); pooled; head 0.5 f0 + 0.25 f1 + 0.1.
  LevelEncoder e;
  e.point_layers.push_back({1, 2, 1, {1.0f, -1.0f}, {0.0f, 3.0f}});
  e.head_layers.push_back({2, 1, 0, {0.5f, 0.25f}, {0.1f}});
  std::vector<float> scratch;
  const std::vector<float> coords = {1.5f, 0.0f, 2.0f, 0.0f};  // two masked points
  // Features (1.5, 1.5) and (2, 1): max (2, 1.5) -> 1.475; mean (1.75, 1.25) -> 1.2875.
  EXPECT_FLOAT_EQ(encode_axis(e, NeuralPooling::max, coords, scratch), 1.475f);
  EXPECT_FLOAT_EQ(encode_axis(e, NeuralPooling::mean, coords, scratch), 1.2875f);
  // No active point: the pooled vector is zero.
  EXPECT_FLOAT_EQ(encode_axis(e, NeuralPooling::max, std::vector<float>(5, 0.0f), scratch), 0.1f);
  // Masked points change nothing; many points (several blocks) are pooled over all of them.
  std::vector<float> many(1000, 0.0f);
  many[3] = 1.5f;
  many[999] = 2.0f;
  EXPECT_FLOAT_EQ(encode_axis(e, NeuralPooling::mean, many, scratch), 1.2875f);

  // A deeper random network against a straightforward evaluation.
  const NeuralModel m = random_model(NeuralCost::sah, 1, NeuralPooling::mean, 11);
  const LevelEncoder& enc = m.levels[0];
  Pcg32 rng(5);
  std::vector<float> xs(300);
  for (float& x : xs) x = (rng.next_u32() % 4 == 0) ? 0.0f : 1.0f + rng.next_float();
  std::vector<double> pooled(8, 0.0);
  int active = 0;
  const auto apply = [](const DenseLayer& l, const std::vector<double>& in) {
    std::vector<double> out(static_cast<std::size_t>(l.out));
    for (int o = 0; o < l.out; ++o) {
      double s = l.bias[static_cast<std::size_t>(o)];
      for (int i = 0; i < l.in; ++i)
        s += l.weight[static_cast<std::size_t>(o * l.in + i)] * in[static_cast<std::size_t>(i)];
      out[static_cast<std::size_t>(o)] = l.activation == 1 ? std::max(0.0, s) : s;
    }
    return out;
  };
  for (const float x : xs) {
    if (x == 0.0f) continue;
    ++active;
    std::vector<double> f = {x};
    for (const DenseLayer& l : enc.point_layers) f = apply(l, f);
    for (int o = 0; o < 8; ++o)
      pooled[static_cast<std::size_t>(o)] += f[static_cast<std::size_t>(o)];
  }
  for (double& p : pooled) p /= active;
  std::vector<double> h = pooled;
  for (const DenseLayer& l : enc.head_layers) h = apply(l, h);
  EXPECT_NEAR(encode_axis(enc, NeuralPooling::mean, xs, scratch), h[0], 1e-5);

  // A batch of inputs (one empty, one of a single point, several blocks long) gives exactly
  // what encode_axis gives for each.
  for (const NeuralPooling pool : {NeuralPooling::max, NeuralPooling::mean}) {
    const std::vector<std::size_t> offsets = {0, 0, 1, 70, 300};
    std::vector<float> out(4);
    encode_groups(enc, pool, xs, offsets, out, scratch);
    for (std::size_t g = 0; g < 4; ++g) {
      const std::span<const float> part(xs.data() + offsets[g], offsets[g + 1] - offsets[g]);
      std::vector<float> fresh;
      EXPECT_EQ(out[g], encode_axis(enc, pool, part, fresh)) << g;
    }
  }
}

void expect_valid_top(const NeuralTop& top, int max_depth) {
  ASSERT_FALSE(top.nodes.empty());
  EXPECT_LE(top.depth, max_depth);
  for (const NeuralTopNode& n : top.nodes) {
    if (n.leaf()) continue;
    EXPECT_GT(n.split, n.box.lo[n.axis]);
    EXPECT_LT(n.split, n.box.hi[n.axis]);
    const Aabb& a = top.nodes[static_cast<std::size_t>(n.child[0])].box;
    const Aabb& b = top.nodes[static_cast<std::size_t>(n.child[1])].box;
    EXPECT_EQ(a.hi[n.axis], n.split);
    EXPECT_EQ(b.lo[n.axis], n.split);
    EXPECT_EQ(a.lo[n.axis], n.box.lo[n.axis]);
    EXPECT_EQ(b.hi[n.axis], n.box.hi[n.axis]);
  }
}

TEST(NeuralTop, GreedyInferenceGivesAValidTopIndependentOfThreads) {
  const std::vector<Triangle> tris = load_triangles(vendored_file("horse/horse.obj.gz"));
  const NeuralModel model = read_neural_model(model_file(NeuralCost::sah, 6));
  const Aabb box = bounds_of(tris);
  BuildConfig config;
  config.neural.top_min = 0;  // every node down to the model's depth
  TriangleTop one, two;
  {
    ThreadLimit limit(1);
    one = infer_triangle_top(model, tris, box, config);
  }
  {
    ThreadLimit limit(2);
    two = infer_triangle_top(model, tris, box, config);
  }
  expect_valid_top(one.top, 6);
  EXPECT_EQ(one.top.depth, 6);  // 16.8k triangles: splitting always pays at the top
  EXPECT_EQ(one.top.leaves(), 64u);
  ASSERT_EQ(one.top.nodes.size(), two.top.nodes.size());
  for (std::size_t i = 0; i < one.top.nodes.size(); ++i) {
    EXPECT_EQ(one.top.nodes[i].axis, two.top.nodes[i].axis);
    EXPECT_EQ(one.top.nodes[i].split, two.top.nodes[i].split);
  }
  // The samples are reproducible and lie on the surface's bounds.
  const SurfaceSampler sampler(tris);
  const auto a = sampler.sample(500), b = sampler.sample(500);
  ASSERT_EQ(a.size(), 500u);
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].x, b[i].x);
    EXPECT_TRUE(box.contains(a[i]));
  }
  // A model of fewer levels than asked for infers only its own.
  NeuralTopOptions options;
  options.max_depth = 2;
  const NeuralTop shallow = infer_neural_top(model, a, box, options);
  EXPECT_LE(shallow.depth, 2);
  expect_valid_top(shallow, 2);
}

TEST(NeuralTop, SmallInputsStopEarly) {
  // With a handful of primitives the local cost says "leaf" long before the model's depth.
  const NeuralModel model = random_model(NeuralCost::sah, 6, NeuralPooling::max, 42);
  std::vector<Vec3> samples = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 1}};
  NeuralTopOptions options;
  options.population = 4;
  const NeuralTop top = infer_neural_top(model, samples, {{0, 0, 0}, {1, 1, 1}}, options);
  EXPECT_LT(top.depth, 6);
  expect_valid_top(top, 6);
}

void expect_neural_matches_brute(const Reference& ref, const std::string& accel,
                                 const std::string& expand, const std::string& model,
                                 const std::string& what) {
  BuildConfig config;
  config.builder = "neural";
  config.neural.model = model;
  config.neural.expand = expand;
  config.neural.top_min = 0;  // the deepest top the model gives: the hardest case for the answers
  const auto tree = make_accel(accel, ref.tris, config);
  EXPECT_EQ(tree->stats().accel, accel);
  EXPECT_TRUE(tree->stats().inference_ms.has_value());
  ASSERT_TRUE(tree->stats().top_depth.has_value());
  EXPECT_GT(*tree->stats().top_depth, 0);
  EXPECT_TRUE(tree->stats().sah_cost.has_value());
  expect_same_answers(ref.brute, answers_of(*tree, ref.rays), ref.rays,
                      what + " " + accel + " neural+" + expand);
}

TEST(NeuralAccel, KdTreesMatchBruteOnHorseWithEveryExpander) {
  const std::string model = model_file(NeuralCost::sah, 6);
  for (const std::string expand : {"sah", "golden", "binned"})
    expect_neural_matches_brute(reference(vendored_file("horse/horse.obj.gz")), "kd", expand, model,
                                "horse");
}

TEST(NeuralAccel, BvhsMatchBruteOnHorseWithEveryExpander) {
  const std::string model = model_file(NeuralCost::sah, 6);
  for (const std::string expand : {"binned", "sbvh", "embree"})
    expect_neural_matches_brute(reference(vendored_file("horse/horse.obj.gz")), "bvh", expand,
                                model, "horse");
}

TEST(NeuralAccel, SmallCellsAreLeftToTheExpansionBuilder) {
  SPLITRAY_REQUIRE_SHARED(cornell, "static_cornell_box/cornell_box.obj");
  const std::string model = model_file(NeuralCost::sah, 6);
  const auto build = [&](const std::vector<Triangle>& tris, const std::string& builder,
                         int top_min) {
    BuildConfig config;
    config.builder = builder;
    config.neural.model = model;
    config.neural.top_min = top_min;
    return make_accel("kd", tris, config)->stats();
  };
  // 36 triangles, fewer than the default threshold: no top, exactly the expansion's tree.
  const std::vector<Triangle> room = load_triangles(cornell);
  const AccelStats small = build(room, "neural", kNeuralTopMinPrims);
  EXPECT_EQ(*small.top_depth, 0);
  EXPECT_EQ(*small.sah_cost, *build(room, "sah", kNeuralTopMinPrims).sah_cost);
  EXPECT_EQ(small.nodes, build(room, "sah", kNeuralTopMinPrims).nodes);
  // 16.8k triangles: the default stops where cells hold about 4096, 0 goes to the model's 6.
  const std::vector<Triangle> horse = load_triangles(vendored_file("horse/horse.obj.gz"));
  const int shallow = *build(horse, "neural", kNeuralTopMinPrims).top_depth;
  EXPECT_GT(shallow, 0);
  EXPECT_LT(shallow, 6);
  EXPECT_EQ(*build(horse, "neural", 0).top_depth, 6);
}

// The network's baseline (paper 003 Fig. 3): the root split of the samples' greedy top is the
// cheapest of every split at a sample coordinate on every axis, small cells stay leaves, and
// the tree built on it (--greedy-top) answers like brute.
TEST(NeuralTop, GreedyTopTakesTheSamplesCheapestSplitAndMatchesBrute) {
  const std::vector<Triangle> tris = load_triangles(vendored_file("horse/horse.obj.gz"));
  const std::vector<Vec3> samples = SurfaceSampler(tris).sample(2048);
  Aabb root;
  for (const Triangle& t : tris) root.extend(t.bounds());
  NeuralTopOptions options;
  options.population = static_cast<double>(tris.size());
  options.max_depth = 6;
  const NeuralTop top = greedy_top(samples, root, options);
  expect_valid_top(top, 6);
  ASSERT_FALSE(top.nodes[0].leaf());
  const double scale = neural_sample_scale(samples.size(), options);
  const double parent = neural_cell_measure(root, options.cost, options.radius);
  double best = std::numeric_limits<double>::infinity();
  for (int axis = 0; axis < 3; ++axis)
    for (const Vec3& p : samples) {
      const float split = p[axis];
      if (!(split > root.lo[axis] && split < root.hi[axis])) continue;
      std::size_t below = 0;
      for (const Vec3& q : samples) below += q[axis] < split ? 1 : 0;
      best = std::min(best, neural_split_cost(root, axis, split, below, samples.size(), parent,
                                              scale, options));
    }
  std::size_t below = 0;
  for (const Vec3& q : samples) below += q[top.nodes[0].axis] < top.nodes[0].split ? 1 : 0;
  EXPECT_EQ(neural_split_cost(root, top.nodes[0].axis, top.nodes[0].split, below, samples.size(),
                              parent, scale, options),
            best);
  options.min_split_population = 1e9;  // every cell "too small": the root stays a leaf
  EXPECT_EQ(greedy_top(samples, root, options).depth, 0);

  BuildConfig config;
  config.builder = "neural";
  config.neural.model = model_file(NeuralCost::sah, 6);
  config.neural.greedy_top = true;
  config.neural.top_min = 0;
  const auto tree = make_accel("kd", tris, config);
  EXPECT_EQ(tree->stats().builder, "greedy-top+sah");
  EXPECT_GT(*tree->stats().top_depth, 0);
  const Reference ref = reference(vendored_file("horse/horse.obj.gz"));
  expect_same_answers(ref.brute, answers_of(*tree, ref.rays), ref.rays, "horse greedy-top+sah");
}

TEST(NeuralAccel, KdAndBvhMatchBruteOnSharedMeshes) {
  SPLITRAY_REQUIRE_SHARED(cornell, "static_cornell_box/cornell_box.obj");
  SPLITRAY_REQUIRE_SHARED(sibenik, "static_sibenik/sibenik.obj");
  const std::string model = model_file(NeuralCost::sah, 6);
  for (const auto& [path, name] :
       {std::pair{cornell, "cornell box"}, std::pair{sibenik, "sibenik"}}) {
    expect_neural_matches_brute(reference(path, 6000), "kd", "sah", model, name);
    expect_neural_matches_brute(reference(path, 6000), "bvh", "binned", model, name);
  }
}

TEST(NeuralAccel, KdTreeDoesNotDependOnThreadCount) {
  const std::vector<Triangle> tris = load_triangles(vendored_file("horse/horse.obj.gz"));
  BuildConfig config;
  config.builder = "neural";
  config.neural.model = model_file(NeuralCost::sah, 6);
  config.threads = 1;
  const auto one = make_accel("kd", tris, config);
  config.threads = 2;
  const auto two = make_accel("kd", tris, config);
  const auto& a = dynamic_cast<const KdAccel*>(one.get());
  EXPECT_EQ(a, nullptr);  // wrapped: compare through the statistics and the answers
  EXPECT_EQ(one->stats().nodes, two->stats().nodes);
  EXPECT_EQ(one->stats().prim_refs, two->stats().prim_refs);
  EXPECT_EQ(*one->stats().sah_cost, *two->stats().sah_cost);
  const std::vector<Ray> rays = hard_rays(tris, 4000, 9);
  const Answers x = answers_of(*one, rays), y = answers_of(*two, rays);
  for (std::size_t i = 0; i < rays.size(); ++i) EXPECT_TRUE(same_hit(x.hits[i], y.hits[i]));
}

TEST(NeuralAccel, BadModelsAndExpandersAreClearErrors) {
  const std::vector<Triangle> tris = load_triangles(vendored_file("horse/horse.obj.gz"));
  BuildConfig config;
  config.builder = "neural";
  config.neural.model = model_file(NeuralCost::vvh, 5);
  EXPECT_THROW(make_accel("kd", tris, config), Error);  // a VVH model for ray tracing
  config.neural.model = model_file(NeuralCost::sah, 6);
  config.neural.expand = "nope";
  EXPECT_THROW(make_accel("kd", tris, config), Error);
  EXPECT_THROW(make_accel("bvh", tris, config), Error);
  config.neural.expand = "neural";
  EXPECT_THROW(make_accel("kd", tris, config), Error);
  config.neural.expand = "";
  config.neural.model = "/nonexistent/model.bin";
  try {
    make_accel("bvh", tris, config);
    ADD_FAILURE() << "no error for a missing model";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/model.bin"), std::string::npos);
  }
  config.neural.model = model_file(NeuralCost::sah, 6);
  EXPECT_THROW(make_accel("bih", tris, config), Error);  // not a builder of bih
}

TEST(NeuralAccel, DefaultModelsAreFoundThroughTheModelDir) {
  const std::filesystem::path dir = temp_dir("neural-model-dir");
  write_neural_model(random_model(NeuralCost::sah, 4, NeuralPooling::max, 42),
                     (dir / "sah.bin").string());
  const char* old = std::getenv("SPLITRAY_MODEL_DIR");
  const std::string saved = old ? old : "";
  ::setenv("SPLITRAY_MODEL_DIR", dir.c_str(), 1);
  EXPECT_EQ(find_default_model(NeuralCost::sah), (dir / "sah.bin").string());
  const std::vector<Triangle> tris = load_triangles(vendored_file("horse/horse.obj.gz"));
  BuildConfig config;
  config.builder = "neural";
  config.neural.top_min = 0;
  const auto tree = make_accel("kd", tris, config);  // no --model: the folder's sah.bin
  EXPECT_EQ(*tree->stats().top_depth, 4);
  if (old)
    ::setenv("SPLITRAY_MODEL_DIR", saved.c_str(), 1);
  else
    ::unsetenv("SPLITRAY_MODEL_DIR");
}

void expect_same_knn(const KnnResult& expected, const KnnResult& actual, const std::string& what) {
  ASSERT_EQ(expected.indices.size(), actual.indices.size()) << what;
  std::size_t mismatches = 0;
  for (std::size_t i = 0; i < expected.indices.size(); ++i)
    if (expected.indices[i] != actual.indices[i] || expected.distances[i] != actual.distances[i])
      ++mismatches;
  EXPECT_EQ(mismatches, 0u) << what;
}

TEST(NeuralPointTree, EqualsBruteForceForKNearestAndRadius) {
  const Mesh mesh = load_mesh(vendored_file("horse/horse.obj.gz"));
  std::vector<Vec3> points = sample_surface(mesh, 20000, 7, kPointStream);
  for (int copy = 0; copy < 30; ++copy) points.push_back(points[100]);  // a cluster over a leaf
  std::vector<Vec3> queries = sample_surface(mesh, 1500, 7, kQueryStream);
  for (std::size_t i = 0; i < points.size(); i += 211) queries.push_back(points[i]);
  Aabb box;
  for (const Vec3& p : points) box.extend(p);
  queries.push_back(box.hi + box.extent());

  PointTreeConfig config;
  config.builder = "neural";
  config.neural.model = model_file(NeuralCost::vvh, 5);
  for (const std::string expand : {"vvh", "median"}) {
    config.neural.expand = expand;
    const PointTree tree(points, config);
    const PointTreeStats stats = tree.stats();
    EXPECT_TRUE(stats.inference_ms.has_value());
    EXPECT_GT(stats.top_depth, 0);
    EXPECT_GT(stats.vvh_cost, 0);
    for (const int k : {1, 8, 50})
      expect_same_knn(brute_force_knn(points, queries, k), tree.knn(queries, k),
                      "neural+" + expand + " k=" + std::to_string(k));
    const float r = 0.02f * length(box.extent());
    const RadiusResult expected = brute_force_radius(points, queries, r);
    const RadiusResult actual = tree.radius(queries, r);
    EXPECT_EQ(expected.offsets, actual.offsets);
    EXPECT_EQ(expected.indices, actual.indices);
    EXPECT_EQ(expected.distances, actual.distances);
    // Every point is in the leaf its own point-in-leaf query finds.
    for (std::size_t i = 0; i < points.size(); i += 997) {
      const auto leaf = tree.leaf_points(points[i]);
      bool found = false;
      for (const std::uint32_t j : leaf) found = found || points[j].x == points[i].x;
      EXPECT_TRUE(found) << i;
    }
  }
  // Thread count does not change the tree.
  config.neural.expand = "";
  std::vector<PointNode> one, two;
  {
    ThreadLimit limit(1);
    const PointTree tree(points, config);
    one.assign(tree.nodes().begin(), tree.nodes().end());
  }
  {
    ThreadLimit limit(2);
    const PointTree tree(points, config);
    two.assign(tree.nodes().begin(), tree.nodes().end());
  }
  ASSERT_EQ(one.size(), two.size());
  EXPECT_EQ(std::memcmp(one.data(), two.data(), one.size() * sizeof(PointNode)), 0);
  // A SAH model is refused for points.
  config.neural.model = model_file(NeuralCost::sah, 6);
  EXPECT_THROW(PointTree(points, config), Error);
}

// A leaf cell of a top keeps the top's extent on the axes it was not split on. A flat patch
// (z = 0) cut off from a tall column by a top split on x sits in a cell 10 high: its
// expansion must shed that height by an empty-space cut (no plane between its points can),
// so that the patch's leaves are flat cells, and the tree costs no more than one built alone.
TEST(NeuralPointTree, ExpandedCellsShedTheTopsEmptySpace) {
  Pcg32 rng(3);
  std::vector<Vec3> points;
  points.reserve(40000);
  for (int i = 0; i < 20000; ++i) points.push_back({rng.next_float(), rng.next_float(), 0.0f});
  for (int i = 0; i < 20000; ++i)
    points.push_back({2 + rng.next_float(), rng.next_float(), 10 * rng.next_float()});
  Aabb bounds;
  for (const Vec3& p : points) bounds.extend(p);
  NeuralTop top;
  top.nodes.resize(3);
  top.nodes[0].box = bounds;
  top.nodes[0].axis = 0;
  top.nodes[0].split = 1.5f;
  top.nodes[0].child[0] = 1;
  top.nodes[0].child[1] = 2;
  top.depth = 1;
  PointTreeConfig config;
  const float radius = 1e-4f * length(bounds.extent());
  const PointBuildOutput expanded = expand_point_top(points, bounds, top, config, radius);
  const PointBuildOutput alone = build_point_tree(points, bounds, config, radius);
  const double cost_expanded = vvh_tree_cost(expanded.nodes, bounds, config, radius);
  const double cost_alone = vvh_tree_cost(alone.nodes, bounds, config, radius);
  EXPECT_LT(cost_expanded, 1.1 * cost_alone) << cost_expanded << " vs " << cost_alone;
  struct Entry {
    std::uint32_t node;
    Aabb cell;
  };
  std::vector<Entry> stack{{0, bounds}};
  std::size_t patch_leaves = 0;
  while (!stack.empty()) {
    const auto [index, cell] = stack.back();
    stack.pop_back();
    const PointNode& n = expanded.nodes[index];
    if (n.is_leaf()) {
      if (n.count() > 0 && points[expanded.permutation[n.index]].x < 1.5f) {
        ++patch_leaves;
        ASSERT_EQ(cell.hi.z, cell.lo.z)
            << "a leaf of the flat patch in a cell of height " << cell.hi.z - cell.lo.z;
      }
      continue;
    }
    Aabb below = cell, above = cell;
    below.hi[n.axis()] = n.below_max;
    above.lo[n.axis()] = n.above_min;
    stack.push_back({index + 1, below});
    stack.push_back({index + n.index, above});
  }
  EXPECT_GT(patch_leaves, 1000u);
  std::vector<std::uint32_t> sorted = expanded.permutation;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], i);
}

TEST(NeuralPointTree, TinyAndDegenerateInputsEqualBruteForce) {
  PointTreeConfig config;
  config.builder = "neural";
  config.neural.model = model_file(NeuralCost::vvh, 5);
  const std::vector<std::vector<Vec3>> sets = {
      {{1, 2, 3}},
      std::vector<Vec3>(50, Vec3{1, 1, 1}),
      [] {
        std::vector<Vec3> line;
        for (int i = 0; i < 3000; ++i) line.push_back({static_cast<float>(i % 97), 0, 0});
        return line;
      }(),
  };
  for (const auto& points : sets) {
    const PointTree tree(points, config);
    const std::vector<Vec3> queries = {{0, 0, 0}, {5.5f, 0.1f, 0}, {1, 1, 1}};
    const int k = static_cast<int>(std::min<std::size_t>(5, points.size()));
    expect_same_knn(brute_force_knn(points, queries, k), tree.knn(queries, k), "degenerate");
  }
}

// The SHIPPED weights (models/, trained by splitray-train), not random ones: their tops,
// expanded, answer exactly like brute force (kd and BVH on two meshes, k-NN on points).
TEST(ShippedModels, TopsFromTheShippedWeightsAnswerLikeBrute) {
  const std::string dir = std::string(SPLITRAY_SOURCE_DIR) + "/models/";
  ASSERT_TRUE(std::ifstream(dir + "sah.bin").good()) << dir << "sah.bin is not shipped";
  ASSERT_TRUE(std::ifstream(dir + "vvh.bin").good()) << dir << "vvh.bin is not shipped";
  EXPECT_EQ(read_neural_model(dir + "sah.bin").depth(), 6);
  EXPECT_EQ(read_neural_model(dir + "vvh.bin").depth(), 5);
  for (const std::string mesh : {"horse/horse.obj.gz", "dragon_100k/dragon.obj.gz"}) {
    const Reference& ref = reference(vendored_file(mesh), 6000);
    expect_neural_matches_brute(ref, "kd", "sah", dir + "sah.bin", mesh + " shipped");
    expect_neural_matches_brute(ref, "bvh", "binned", dir + "sah.bin", mesh + " shipped");
  }
  const Mesh mesh = load_mesh(vendored_file("dragon_100k/dragon.obj.gz"));
  const std::vector<Vec3> points = sample_surface(mesh, 50000, 3, kPointStream);
  const std::vector<Vec3> queries = sample_surface(mesh, 1000, 3, kQueryStream);
  PointTreeConfig config;
  config.builder = "neural";
  config.neural.model = dir + "vvh.bin";
  const PointTree tree(points, config);
  EXPECT_GT(tree.stats().top_depth, 0);
  for (const int k : {1, 8})
    expect_same_knn(brute_force_knn(points, queries, k), tree.knn(queries, k),
                    "shipped vvh k=" + std::to_string(k));
}

}  // namespace
}  // namespace splitray::test

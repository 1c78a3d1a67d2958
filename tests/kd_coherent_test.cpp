// Coherent kd rebuilds (issue #20): on every frame of real sequences the tree answers closest
// and any hits exactly as brute force does, it is the same tree for 1 and 2 threads, a sudden
// jump (frames out of order, a teleported object) is rebuilt where it broke and stays exact,
// and a frame with another triangle count is refused.
#include <gtest/gtest.h>

#include "splitray/accel/accel.hpp"
#include "splitray/accel/kd/coherent_builder.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/io/frames.hpp"
#include "splitray/render/ray_sets.hpp"
#include "test_data.hpp"

namespace splitray {
namespace {

namespace fs = std::filesystem;

std::vector<std::vector<Triangle>> shared_frames(const std::string& first_file,
                                                 const std::string& pattern, std::size_t count) {
  const std::string first = test::shared_file(first_file);
  if (first.empty()) return {};
  return load_frames(FrameSequence({(fs::path(first).parent_path() / pattern).string()}), count);
}

void expect_brute(const Accel& kd, std::span<const Triangle> triangles, std::uint64_t seed,
                  const std::string& what) {
  const auto brute = make_accel("brute", triangles);
  for (const RayKind kind : {RayKind::primary, RayKind::random}) {
    const std::vector<Ray> rays = make_rays(triangles, kind, seed, 300);
    std::vector<Hit> a(rays.size()), b(rays.size());
    std::vector<std::uint8_t> oa(rays.size()), ob(rays.size());
    kd.intersect(rays, a);
    brute->intersect(rays, b);
    kd.occluded(rays, oa);
    brute->occluded(rays, ob);
    std::size_t bad = 0, bad_any = 0;
    for (std::size_t r = 0; r < rays.size(); ++r) {
      bad += a[r].prim != b[r].prim || a[r].t != b[r].t;
      bad_any += oa[r] != ob[r];
    }
    EXPECT_EQ(bad, 0u) << what << ": closest hits differ from brute force";
    EXPECT_EQ(bad_any, 0u) << what << ": any hits differ from brute force";
  }
}

bool same_tree(const KdTree& a, const KdTree& b) {
  if (a.nodes.size() != b.nodes.size() || a.prim_ids != b.prim_ids) return false;
  for (std::size_t i = 0; i < a.nodes.size(); ++i)
    if (a.nodes[i].bits != b.nodes[i].bits || a.nodes[i].prim_offset != b.nodes[i].prim_offset)
      return false;
  return true;
}

// Every frame equals brute force; 1 and 2 threads make identical trees; frames after the
// first keep part of the previous tree.
void check_sequence(const std::vector<std::vector<Triangle>>& frames, const std::string& name) {
  ASSERT_GE(frames.size(), 3u) << name;
  BuildConfig one, two;
  one.threads = 1;
  two.threads = 2;
  KdCoherentBuilder a(one, PredictorConfig{}), b(two, PredictorConfig{});
  std::size_t reused = 0, nodes = 0;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    CoherentFrameStats sa, sb;
    const auto ta = a.next_frame(frames[f], sa);
    const auto tb = b.next_frame(frames[f], sb);
    EXPECT_TRUE(same_tree(ta->tree(), tb->tree())) << name << " frame " << f;
    if (f == 0) {
      EXPECT_TRUE(sa.from_scratch) << name;
    }
    EXPECT_EQ(sa.from_scratch, !sa.reason.empty()) << name << " frame " << f << ": " << sa.reason;
    if (f > 0) {
      reused += sa.reused_nodes + sa.reoptimised_nodes;
      nodes += ta->stats().nodes;
    }
    EXPECT_EQ(sa.reused_nodes + sa.reoptimised_nodes + sa.rebuilt_nodes, ta->stats().nodes);
    expect_brute(*ta, frames[f], 11 + f, name + " frame " + std::to_string(f));
  }
  // Deforming meshes rebuild much of the tree (README); a coherent rebuild that keeps nothing
  // would be a from-scratch build in disguise.
  EXPECT_GT(reused, nodes / 20) << name << ": the tree should be partly kept between frames";
}

TEST(KdCoherent, EqualsBruteOnHorseCollapse) {
  const auto frames = shared_frames("anim_horse_collapse/frames/horse-collapse-01.obj.gz",
                                    "horse-collapse-%02d.obj.gz", 6);
  if (frames.empty()) GTEST_SKIP() << "anim_horse_collapse absent";
  check_sequence(frames, "horse collapse");
}

TEST(KdCoherent, EqualsBruteOnElephantGallop) {
  const auto frames = shared_frames("anim_elephant_gallop/frames/elephant-gallop-01.obj.gz",
                                    "elephant-gallop-%02d.obj.gz", 3);
  if (frames.empty()) GTEST_SKIP() << "anim_elephant_gallop absent";
  check_sequence(frames, "elephant gallop");
}

TEST(KdCoherent, EqualsBruteOnMd2Faerie) {
  const auto frames = shared_frames("anim_md2_faerie/frames/faerie_000.obj", "faerie_%03d.obj", 6);
  if (frames.empty()) GTEST_SKIP() << "anim_md2_faerie absent";
  check_sequence(frames, "md2 faerie");
}

// Frames out of order and an object teleported: the broken parts are rebuilt and every
// frame stays exact.
TEST(KdCoherent, SuddenJumpsStayExact) {
  auto frames = shared_frames("anim_horse_collapse/frames/horse-collapse-01.obj.gz",
                              "horse-collapse-%02d.obj.gz", 53);
  if (frames.empty()) GTEST_SKIP() << "anim_horse_collapse absent";
  std::vector<Triangle> teleported = frames[2];
  Aabb bounds;
  for (const Triangle& t : teleported) bounds.extend(t.bounds());
  const Vec3 jump = bounds.extent() * 0.8f;  // a third of the horse leaves it
  for (std::size_t i = 0; i < teleported.size() / 3; ++i) {
    teleported[i].v0 += jump;
    teleported[i].v1 += jump;
    teleported[i].v2 += jump;
  }
  KdCoherentBuilder builder(BuildConfig{}, PredictorConfig{});
  std::size_t rebuilt_subtrees = 0;
  const std::vector<const std::vector<Triangle>*> order = {&frames[0],  &frames[52], &frames[1],
                                                           &teleported, &frames[3],  &frames[30]};
  for (std::size_t f = 0; f < order.size(); ++f) {
    CoherentFrameStats stats;
    const auto kd = builder.next_frame(*order[f], stats);
    if (f > 0) rebuilt_subtrees += stats.rebuilt_subtrees;
    expect_brute(*kd, *order[f], 40 + f, "jump " + std::to_string(f));
  }
  EXPECT_GT(rebuilt_subtrees, 0u) << "jumps must rebuild what they broke";
}

TEST(KdCoherent, RefusesAnotherTriangleCountAndEmptyFrames) {
  const auto frames = shared_frames("anim_horse_collapse/frames/horse-collapse-01.obj.gz",
                                    "horse-collapse-%02d.obj.gz", 2);
  if (frames.empty()) GTEST_SKIP() << "anim_horse_collapse absent";
  KdCoherentBuilder builder(BuildConfig{}, PredictorConfig{});
  CoherentFrameStats stats;
  EXPECT_THROW(builder.next_frame({}, stats), Error);
  builder.next_frame(frames[0], stats);
  const std::span<const Triangle> fewer(frames[1].data(), frames[1].size() - 1);
  try {
    builder.next_frame(fewer, stats);
    ADD_FAILURE() << "a frame with another triangle count was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(std::to_string(frames[0].size())), std::string::npos)
        << e.what();
  }
  builder.reset();
  EXPECT_NO_THROW(builder.next_frame(fewer, stats));  // a new sequence after reset
  EXPECT_TRUE(stats.from_scratch);
}

}  // namespace
}  // namespace splitray

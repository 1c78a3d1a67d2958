// Animated kd rebuilds (issue #4): predicted trees answer every ray as brute force does on
// every frame, frame sequences refuse a changing triangle count, frame arguments expand,
// and the BART AFF reader reads the museum and names file and line of every problem.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "splitray/accel/accel.hpp"
#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/accel/kd/predicted_builder.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/io/aff.hpp"
#include "splitray/io/frames.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/render/ray_sets.hpp"
#include "test_data.hpp"

namespace splitray {
namespace {

namespace fs = std::filesystem;

void write(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

// Predicted trees over `frames`: closest hits equal brute force's for primary and random
// rays; predictions are used from frame 1 on.
void expect_brute_hits(const std::vector<std::vector<Triangle>>& frames, PredictorKind kind) {
  PredictorConfig config;
  config.kind = kind;
  SplitPredictor predictor(config);
  std::size_t used = 0;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    PredictedBuildStats stats;
    const auto kd = make_kd_predicted(frames[f], BuildConfig{}, predictor, stats);
    if (f > 0) used += stats.predicted_nodes;
    const auto brute = make_accel("brute", frames[f]);
    for (const RayKind rays_kind : {RayKind::primary, RayKind::random}) {
      const std::vector<Ray> rays = make_rays(frames[f], rays_kind, 7 + f, 400);
      std::vector<Hit> a(rays.size()), b(rays.size());
      kd->intersect(rays, a);
      brute->intersect(rays, b);
      std::size_t bad = 0;
      for (std::size_t r = 0; r < rays.size(); ++r)
        bad += a[r].prim != b[r].prim || a[r].t != b[r].t;
      EXPECT_EQ(bad, 0u) << "frame " << f << " " << predictor_name(kind);
    }
  }
  EXPECT_GT(used, 0u) << "no prediction was ever used (" << predictor_name(kind) << ")";
}

TEST(Animate, PredictedTreesEqualBruteOnHorseCollapse) {
  SPLITRAY_REQUIRE_SHARED(first, "anim_horse_collapse/frames/horse-collapse-01.obj.gz");
  const std::string pattern =
      (fs::path(first).parent_path() / "horse-collapse-%02d.obj.gz").string();
  const FrameSequence sequence({pattern});
  EXPECT_EQ(sequence.size(), 53u);
  const auto frames = load_frames(sequence, 8);
  ASSERT_EQ(frames.size(), 8u);
  expect_brute_hits(frames, PredictorKind::kalman);
  expect_brute_hits(frames, PredictorKind::wiener);
}

// Without shared data: the vendored horse, bent a little more every frame.
std::vector<std::vector<Triangle>> bending_horse(int count) {
  const std::vector<Triangle> base =
      load_mesh(test::vendored_file("horse/horse.obj.gz")).triangles();
  Aabb box;
  for (const Triangle& t : base) box.extend(t.bounds());
  std::vector<std::vector<Triangle>> frames;
  for (int f = 0; f < count; ++f) {
    const auto bend = [&](Vec3 p) {
      const float s = (p[0] - box.lo[0]) / (box.hi[0] - box.lo[0]);
      p[1] += 0.03f * f * std::sin(3.0f * s) * (box.hi[1] - box.lo[1]);
      p[2] += 0.01f * f * (box.hi[2] - box.lo[2]);
      return p;
    };
    std::vector<Triangle> tris;
    for (const Triangle& t : base) tris.push_back({bend(t.v0), bend(t.v1), bend(t.v2)});
    frames.push_back(std::move(tris));
  }
  return frames;
}

TEST(Animate, PredictedTreesEqualBruteOnBendingHorse) {
  const auto frames = bending_horse(4);
  expect_brute_hits(frames, PredictorKind::kalman);
  expect_brute_hits(frames, PredictorKind::wiener);
}

TEST(Animate, WithoutPredictionsTheTreeIsGoldens) {
  const auto frames = bending_horse(1);
  PredictorConfig off;
  off.kind = PredictorKind::none;
  SplitPredictor none(off);
  PredictedBuildStats stats;
  const auto predicted = make_kd_predicted(frames[0], BuildConfig{}, none, stats);
  BuildConfig golden;
  golden.builder = "golden";
  const auto full = make_kd(frames[0], golden);
  EXPECT_EQ(predicted->stats().nodes, full->stats().nodes);
  EXPECT_EQ(predicted->stats().sah_cost, full->stats().sah_cost);
  EXPECT_EQ(predicted->stats().cost_evals, full->stats().cost_evals);
  EXPECT_EQ(stats.predicted_nodes, 0u);
}

TEST(Animate, PredictedSahCostStaysClose) {
  const auto frames = bending_horse(4);
  SplitPredictor predictor;
  BuildConfig golden;
  golden.builder = "golden";
  for (std::size_t f = 0; f < frames.size(); ++f) {
    PredictedBuildStats stats;
    const double predicted =
        *make_kd_predicted(frames[f], golden, predictor, stats)->stats().sah_cost;
    const double full = *make_kd(frames[f], golden)->stats().sah_cost;
    EXPECT_LT(predicted, full * 1.05) << "frame " << f;
  }
}

TEST(Frames, ChangingTriangleCountIsRefused) {
  const fs::path dir = test::temp_dir("frames_count");
  write(dir / "f-0.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\n");
  write(dir / "f-1.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n");
  const FrameSequence sequence({(dir / "f-%d.obj").string()});
  ASSERT_EQ(sequence.size(), 2u);
  try {
    load_frames(sequence);
    FAIL() << "a changing triangle count was accepted";
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("f-1.obj"), std::string::npos) << message;
    EXPECT_NE(message.find("frame 1 has 2 triangles"), std::string::npos) << message;
  }
}

TEST(Frames, PatternsGlobsAndFoldersExpand) {
  const fs::path dir = test::temp_dir("frames_expand");
  for (int i = 1; i <= 3; ++i)
    write(dir / ("h-0" + std::to_string(i) + ".obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  const std::vector<std::string> want = {(dir / "h-01.obj").string(), (dir / "h-02.obj").string(),
                                         (dir / "h-03.obj").string()};
  EXPECT_EQ(expand_frame_paths({(dir / "h-%02d.obj").string()}), want);  // starts at 1
  EXPECT_EQ(expand_frame_paths({(dir / "h-*.obj").string()}), want);
  EXPECT_EQ(expand_frame_paths({dir.string()}), want);
  EXPECT_EQ(expand_frame_paths({want[2], want[0]}), (std::vector<std::string>{want[2], want[0]}));
  EXPECT_THROW(expand_frame_paths({(dir / "x-%02d.obj").string()}), Error);
  EXPECT_THROW(expand_frame_paths({(dir / "x-*.obj").string()}), Error);
  EXPECT_THROW(expand_frame_paths({(dir / "missing.obj").string()}), Error);
  EXPECT_THROW(FrameSequence(std::vector<std::string>{}), Error);
}

TEST(Aff, MuseumTriangleCount) {
  SPLITRAY_REQUIRE_SHARED(path, "anim_bart_museum/aff/museum5.aff");
  const AffScene scene = AffScene::load(path);
  // SOURCE.md's 10,274 are the polygons (as fans) and the pillar mesh; the scene adds the
  // 1,024 animated triangles, 10 textured triangles and 8 cones (32 triangles each).
  EXPECT_EQ(scene.triangle_count(), 10274u + 1024u + 10u + 8u * 32u);
  EXPECT_EQ(scene.animation().frames, 300);
  const auto a = scene.triangles_at(scene.animation().start);
  const auto b = scene.triangles_at(0.5 * (scene.animation().start + scene.animation().end));
  ASSERT_EQ(a.size(), b.size());
  std::size_t moved = 0;
  for (std::size_t i = 0; i < a.size(); ++i) moved += a[i].v0 != b[i].v0;
  EXPECT_GT(moved, 500u);   // the art piece's triangles fly
  EXPECT_LT(moved, 2000u);  // the museum stands still
  const FrameSequence sequence({path});
  EXPECT_EQ(sequence.size(), 300u);
}

std::string aff_error(const std::string& text, const std::string& name = "scene.aff") {
  const fs::path dir = test::temp_dir("aff_errors");
  write(dir / name, text);
  try {
    AffScene::load((dir / name).string());
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Aff, ErrorsNameFileAndLine) {
  EXPECT_NE(aff_error("p 3\n0 0 0\n1 0 0\n0 1 0\nbogus 1 2\n")
                .find("scene.aff:5: unknown statement 'bogus'"),
            std::string::npos);
  EXPECT_NE(aff_error("p 3\n0 0 0\n1 0 x\n").find("scene.aff:3: 'x' is not a number"),
            std::string::npos);
  EXPECT_NE(aff_error("p 3\n0 0 0\n1 0 0\n").find("the file ends"), std::string::npos);
  EXPECT_NE(aff_error("xs 1 1 1 0 0 1 0 0 0 0\n{\np 3 0 0 0 1 0 0 0 1 0\n").find("missing '}'"),
            std::string::npos);
  EXPECT_NE(aff_error("}\n").find("'}' without"), std::string::npos);
  EXPECT_NE(
      aff_error("m\nvertices 3\n0 0 0 1 0 0 0 1 0\ntriangles 1\n0 1 7\n").find("out of range"),
      std::string::npos);
  EXPECT_NE(aff_error("p 99999999999\n").find("bad vertex count"), std::string::npos);
  EXPECT_NE(aff_error("i 0 nowhere.aff\n").find("nowhere.aff"), std::string::npos);
  EXPECT_NE(aff_error("i 0 loop.aff\n", "loop.aff").find("nested deeper"), std::string::npos);
  EXPECT_NE(aff_error("p 3\n0 0 0\n1 0 nan\n0 1 0\n").find("non-finite"), std::string::npos);
  EXPECT_NE(aff_error("b 0 0 0\n").find("no triangles"), std::string::npos);
}

TEST(Aff, KeyFramedTransformMovesItsContent) {
  const fs::path dir = test::temp_dir("aff_keys");
  write(dir / "k.aff",
        "% a triangle sliding along x, with comments\n"
        "a 0 2 3\n"
        "k slide { transl 2\n 0  0 0 0  0 0 0\n 2  4 0 0  0 0 0\n }\n"
        "x slide {\n  xs 2 2 2  0 0 1 90  0 0 0 { p 3 1 0 0 0 0 0 0 1 0 }\n}\n"
        "tpa 2\n 0  0 0 5 0 0 1  1 0 5 0 0 1  0 1 5 0 0 1\n 2  0 0 7 0 0 1  1 0 7 0 0 1  0 1 7 0 0 "
        "1\n");
  const AffScene scene = AffScene::load((dir / "k.aff").string());
  ASSERT_EQ(scene.triangle_count(), 2u);
  const auto t0 = scene.triangles_at(0), t2 = scene.triangles_at(2), t1 = scene.triangles_at(1);
  // xs: scale 2, rotate 90 degrees about z: (1, 0, 0) -> (0, 2, 0); then slide by 4 in x.
  EXPECT_NEAR(t0[0].v0[0], 0, 1e-5);
  EXPECT_NEAR(t0[0].v0[1], 2, 1e-5);
  EXPECT_NEAR(t2[0].v0[0], 4, 1e-5);
  EXPECT_NEAR(t1[0].v0[0], 2, 1e-5);  // Hermite with zero tangents at the ends: half way
  EXPECT_NEAR(t1[1].v0[2], 6, 1e-5);  // animated triangle: linear
}

}  // namespace
}  // namespace splitray

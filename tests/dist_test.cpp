// Crop windows and distributed runs end to end: crops tiled over the image assemble to the
// full render; `mpirun -np 2|3 splitray render` (loopback, --oversubscribe) writes the same
// PNG as one process. The MPI tests skip with a message where MPI was not built in.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "test_data.hpp"

namespace fs = std::filesystem;
using splitray::test::quote;
using splitray::test::read_text;

namespace {

const std::string kBinary = SPLITRAY_BINARY_DIR "/apps/splitray/splitray";

struct Outcome {
  int status = -1;
  std::string err;
};

Outcome shell(const std::string& command, const fs::path& dir) {
  const fs::path err = dir / "stderr.txt";
  const int raw =
      std::system((command + " > /dev/null 2> " + quote(err.string()) + " < /dev/null").c_str());
  Outcome run;
  run.status = raw != -1 && WIFEXITED(raw) ? WEXITSTATUS(raw) : 128;
  run.err = read_text(err);
  return run;
}

Outcome run_splitray(const std::string& args, const fs::path& dir) {
  return shell(quote(kBinary) + " " + args, dir);
}

// mpirun as root needs its consent variables; one machine, so --oversubscribe and no
// single-copy mechanism (containers often forbid the ptrace it uses).
Outcome mpirun(int ranks, const std::string& args, const fs::path& dir) {
  return shell("OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 " +
                   quote(SPLITRAY_MPIEXEC) +
                   " --oversubscribe --mca btl_vader_single_copy_mechanism none -np " +
                   std::to_string(ranks) + " " + quote(kBinary) + " " + args,
               dir);
}

#define REQUIRE_MPI() \
  if (std::string(SPLITRAY_MPIEXEC).empty()) GTEST_SKIP() << "built without MPI (mpirun): skipped"

using splitray::test::Png;
using splitray::test::read_png;

fs::path fresh_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  return splitray::test::temp_dir(std::string("dist_") + info->name());
}

// The horse (vendored, real scan data) at an odd size, so that crops do not fall on tiles.
const std::string kScene =
    "render " + quote(splitray::test::vendored_file("horse/horse.obj.gz")) + " -W 203 -H 157 -t 2";

}  // namespace

TEST(Crop, WindowsTileTheImageExactly) {
  const fs::path dir = fresh_dir();
  ASSERT_EQ(run_splitray(kScene + " -o " + quote((dir / "full.png").string()), dir).status, 0);
  const Png full = read_png(dir / "full.png");
  ASSERT_EQ(full.width, 203);
  // Uneven cuts: pixel edges at ceil(W x) meet without gap or overlap.
  const std::vector<double> xs = {0, 0.37, 0.5, 1}, ys = {0, 0.61, 1};
  std::vector<unsigned char> assembled(full.rgb.size(), 0);
  std::vector<int> covered(static_cast<std::size_t>(full.width) * full.height, 0);
  for (std::size_t i = 0; i + 1 < xs.size(); ++i)
    for (std::size_t j = 0; j + 1 < ys.size(); ++j) {
      const fs::path part = dir / ("crop-" + std::to_string(i) + std::to_string(j) + ".png");
      const std::string crop = std::to_string(xs[i]) + "," + std::to_string(xs[i + 1]) + "," +
                               std::to_string(ys[j]) + "," + std::to_string(ys[j + 1]);
      const Outcome run =
          run_splitray(kScene + " --crop " + crop + " -o " + quote(part.string()), dir);
      ASSERT_EQ(run.status, 0) << run.err;
      const Png png = read_png(part);
      const int x0 = static_cast<int>(std::ceil(xs[i] * full.width));
      const int y0 = static_cast<int>(std::ceil(ys[j] * full.height));
      ASSERT_EQ(png.width, static_cast<int>(std::ceil(xs[i + 1] * full.width)) - x0);
      ASSERT_EQ(png.height, static_cast<int>(std::ceil(ys[j + 1] * full.height)) - y0);
      for (int y = 0; y < png.height; ++y)
        for (int x = 0; x < png.width; ++x) {
          const std::size_t at = static_cast<std::size_t>(y0 + y) * full.width + x0 + x;
          ++covered[at];
          for (int c = 0; c < 3; ++c)
            assembled[at * 3 + c] = png.rgb[(static_cast<std::size_t>(y) * png.width + x) * 3 + c];
        }
    }
  for (const int n : covered) ASSERT_EQ(n, 1);
  EXPECT_TRUE(assembled == full.rgb) << "the crops differ from the full image";
  fs::remove_all(dir);
}

TEST(Crop, BadWindowsAreRefusedBeforeAnyWork) {
  const fs::path dir = fresh_dir();
  const fs::path out = dir / "out.png";
  for (const std::string crop : {"0.5,0.5,0,1", "0,1.5,0,1", "0,1,0", "a,b,c,d", "0.5,0.501,0,1"}) {
    const Outcome run =
        run_splitray(kScene + " --crop " + crop + " -o " + quote(out.string()), dir);
    EXPECT_EQ(run.status, 1) << crop;
    EXPECT_NE(run.err.find("--crop " + crop), std::string::npos) << run.err;
    EXPECT_FALSE(fs::exists(out)) << crop;
  }
  fs::remove_all(dir);
}

TEST(MpiRender, TwoAndThreeRanksWriteTheSingleProcessImage) {
  REQUIRE_MPI();
  const fs::path dir = fresh_dir();
  // A larger image of the default scene (reflections, refraction, the dragon), small tiles so
  // that the queue hands out many.
  const std::string args = "-W 400 -H 300 -t 1 --tile-size 32";
  ASSERT_EQ(run_splitray("render " + args + " -o " + quote((dir / "one.png").string()), dir).status,
            0);
  const std::string one = read_text(dir / "one.png");
  ASSERT_FALSE(one.empty());
  for (const int ranks : {2, 3}) {
    const fs::path out = dir / ("ranks" + std::to_string(ranks) + ".png");
    const Outcome run = mpirun(ranks, "render " + args + " -o " + quote(out.string()), dir);
    ASSERT_EQ(run.status, 0) << run.err;
    EXPECT_TRUE(read_text(out) == one) << ranks << " ranks: the PNG differs";
  }
  // A crop window distributed the same way.
  ASSERT_EQ(run_splitray("render " + args + " --crop 0.2,0.9,0.1,0.7 -o " +
                             quote((dir / "crop1.png").string()),
                         dir)
                .status,
            0);
  const Outcome run = mpirun(
      2, "render " + args + " --crop 0.2,0.9,0.1,0.7 -o " + quote((dir / "crop2.png").string()),
      dir);
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_TRUE(read_text(dir / "crop2.png") == read_text(dir / "crop1.png"));
  fs::remove_all(dir);
}

// --mode hybrid under mpirun: bands of rows, each rank with its own OpenGL context, give the
// single process's hybrid image byte for byte.
TEST(MpiRender, HybridBandsOfTwoAndThreeRanksWriteTheSingleProcessImage) {
  REQUIRE_MPI();
  const fs::path dir = fresh_dir();
  const fs::path one = dir / "one.png";
  const Outcome single = run_splitray(kScene + " --mode hybrid -o " + quote(one.string()), dir);
  if (single.status != 0 && single.err.find("OpenGL") != std::string::npos)
    GTEST_SKIP() << "no usable OpenGL here: " << single.err;
  ASSERT_EQ(single.status, 0) << single.err;
  for (const int ranks : {2, 3}) {
    const fs::path out = dir / ("ranks" + std::to_string(ranks) + ".png");
    const Outcome run =
        mpirun(ranks, kScene + " --mode hybrid --tile-size 40 -o " + quote(out.string()), dir);
    ASSERT_EQ(run.status, 0) << run.err;
    EXPECT_TRUE(read_text(out) == read_text(one)) << ranks << " ranks: the hybrid image differs";
  }
  fs::remove_all(dir);
}

TEST(MpiRender, AFailingSceneEndsEveryRankWithOneMessage) {
  REQUIRE_MPI();
  const fs::path dir = fresh_dir();
  const fs::path bad = dir / "bad.obj";
  {
    std::FILE* f = std::fopen(bad.c_str(), "w");
    std::fputs("v 0 0 0\nv 1 0 0\nf 1 2 9\n", f);
    std::fclose(f);
  }
  const fs::path out = dir / "out.png";
  const Outcome run =
      mpirun(2, "render " + quote(bad.string()) + " -o " + quote(out.string()), dir);
  EXPECT_NE(run.status, 0);
  EXPECT_NE(run.err.find("bad.obj"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(out));
  fs::remove_all(dir);
}

namespace {

// A short real sequence (the collapsing horse, ../shared/data) at a small size: seconds.
const std::string kFrames = "anim_horse_collapse/frames";
const std::string kAnimate = " --frames 5 -W 96 -H 72 -t 1 --rays 0";

std::string frame_name(int frame) {
  char name[32];
  std::snprintf(name, sizeof name, "frame-%04d.png", frame);
  return name;
}

// The collapsing horse's single-process frames, rendered once for the tests below.
fs::path reference_frames(const fs::path& dir, const std::string& frames) {
  const fs::path one = dir / "one";
  const Outcome single =
      run_splitray("animate " + frames + kAnimate + " --render " + quote(one.string()), dir);
  EXPECT_EQ(single.status, 0) << single.err;
  return one;
}

}  // namespace

TEST(MpiAnimate, TwoAndThreeRanksWriteTheSingleProcessFrames) {
  REQUIRE_MPI();
  SPLITRAY_REQUIRE_SHARED(first, kFrames + "/horse-collapse-01.obj.gz");
  const fs::path dir = fresh_dir();
  const std::string frames = quote(fs::path(first).parent_path().string());
  const fs::path one = reference_frames(dir, frames);
  ASSERT_FALSE(::testing::Test::HasFailure());
  for (const int ranks : {2, 3}) {
    const fs::path out = dir / ("ranks" + std::to_string(ranks));
    const fs::path json = dir / ("ranks" + std::to_string(ranks) + ".json");
    // Runs of two frames: the second of each is built from the rank's predictor.
    const Outcome run = mpirun(ranks,
                               "animate " + frames + kAnimate + " --run-length 2 --render " +
                                   quote(out.string()) + " --json-out " + quote(json.string()),
                               dir);
    ASSERT_EQ(run.status, 0) << run.err;
    for (int f = 0; f < 5; ++f)
      EXPECT_TRUE(read_text(out / frame_name(f)) == read_text(one / frame_name(f)))
          << ranks << " ranks: " << frame_name(f) << " differs";
    const auto report = nlohmann::json::parse(read_text(json));
    EXPECT_EQ(report["rendered"], 5);
    EXPECT_EQ(report["rank_stats"].size(), static_cast<std::size_t>(ranks));
    int predicted = 0;
    for (const auto& row : report["frame_rows"]) predicted += row["predicted"].get<bool>();
    EXPECT_GE(predicted, 1) << "no rank kept its predictor over consecutive frames";
  }
  fs::remove_all(dir);
}

// The hybrid renderer on every rank (its own headless OpenGL context): the frames are the
// single-process hybrid frames, byte for byte.
TEST(MpiAnimate, HybridFramesOfTwoRanksAreTheSingleProcessFrames) {
  REQUIRE_MPI();
  SPLITRAY_REQUIRE_SHARED(first, kFrames + "/horse-collapse-01.obj.gz");
  const fs::path dir = fresh_dir();
  const std::string frames = quote(fs::path(first).parent_path().string());
  const fs::path one = dir / "hybrid";
  const Outcome single = run_splitray("animate " + frames + kAnimate + " --mode hybrid --render " +
                                          quote(one.string()) + " --render-only",
                                      dir);
  if (single.status != 0 && single.err.find("OpenGL") != std::string::npos)
    GTEST_SKIP() << "no usable OpenGL here: " << single.err;
  ASSERT_EQ(single.status, 0) << single.err;
  const fs::path whitted = reference_frames(dir, frames);
  const fs::path out = dir / "ranks2";
  const Outcome run = mpirun(
      2, "animate " + frames + kAnimate + " --mode hybrid --render " + quote(out.string()), dir);
  ASSERT_EQ(run.status, 0) << run.err;
  bool differs_from_whitted = false;
  for (int f = 0; f < 5; ++f) {
    EXPECT_TRUE(read_text(out / frame_name(f)) == read_text(one / frame_name(f)))
        << "hybrid " << frame_name(f) << " differs from the single-process frame";
    differs_from_whitted = differs_from_whitted ||
                           read_text(out / frame_name(f)) != read_text(whitted / frame_name(f));
  }
  EXPECT_TRUE(differs_from_whitted) << "--mode hybrid rendered the Whitted frames";
  fs::remove_all(dir);
}

// `splitray bench dist` end to end on a tiny run: every rank count writes the single process's
// frames, and the report has its rows and the projection.
TEST(BenchDist, ReportsIdenticalImagesAndAProjection) {
  REQUIRE_MPI();
  SPLITRAY_REQUIRE_SHARED(first, kFrames + "/horse-collapse-01.obj.gz");
  const fs::path dir = fresh_dir();
  const fs::path json = dir / "dist.json";
  const Outcome run = run_splitray(
      "bench dist --frames-of " + quote(fs::path(first).parent_path().string()) +
          " --frames 3 -W 48 -H 36 --runs 1 --ranks 2 --json-out " + quote(json.string()),
      dir);
  ASSERT_EQ(run.status, 0) << run.err;
  const auto report = nlohmann::json::parse(read_text(json));
  ASSERT_EQ(report["rows"].size(), 2u);  // the single process and 2 ranks
  for (const auto& row : report["rows"]) {
    EXPECT_TRUE(row["identical_images"].get<bool>()) << row.dump();
    EXPECT_GT(row["frames_per_s"].get<double>(), 0) << row.dump();
  }
  EXPECT_EQ(report["projection"].size(), 4u);
  EXPECT_NE(report["sequence"].get<std::string>().front(), '/')
      << "the report names the project-relative path, not " << report["sequence"];
  fs::remove_all(dir);
}

TEST(MpiAnimate, ResumeRendersOnlyTheMissingAndBrokenFrames) {
  REQUIRE_MPI();
  SPLITRAY_REQUIRE_SHARED(first, kFrames + "/horse-collapse-01.obj.gz");
  const fs::path dir = fresh_dir();
  const std::string frames = quote(fs::path(first).parent_path().string());
  const fs::path one = reference_frames(dir, frames);
  ASSERT_FALSE(::testing::Test::HasFailure());
  // A run that was stopped: frame 1 never written, frame 3 cut off half way.
  const fs::path out = dir / "resumed";
  fs::copy(one, out);
  fs::remove(out / frame_name(1));
  fs::resize_file(out / frame_name(3), fs::file_size(out / frame_name(3)) / 2);
  const fs::path json = dir / "resumed.json";
  const Outcome run = mpirun(2,
                             "animate " + frames + kAnimate + " --resume --render " +
                                 quote(out.string()) + " --json-out " + quote(json.string()),
                             dir);
  ASSERT_EQ(run.status, 0) << run.err;
  const auto report = nlohmann::json::parse(read_text(json));
  EXPECT_EQ(report["rendered"], 2);
  EXPECT_EQ(report["kept"], nlohmann::json::array({0, 2, 4}));
  for (int f = 0; f < 5; ++f)
    EXPECT_TRUE(read_text(out / frame_name(f)) == read_text(one / frame_name(f)))
        << frame_name(f) << " differs after --resume";
  fs::remove_all(dir);
}

TEST(MpiAnimate, ACorruptFrameEndsEveryRankWithOneMessageAndNoPartialImage) {
  REQUIRE_MPI();
  SPLITRAY_REQUIRE_SHARED(first, kFrames + "/horse-collapse-01.obj.gz");
  const fs::path dir = fresh_dir();
  const fs::path frames = dir / "frames";
  fs::create_directories(frames);
  for (int f = 1; f <= 5; ++f) {
    const std::string name = "horse-collapse-0" + std::to_string(f) + ".obj.gz";
    fs::copy_file(fs::path(first).parent_path() / name, frames / name);
  }
  // Frame 3 (index 2) cut off inside its gzip stream.
  const fs::path broken = frames / "horse-collapse-03.obj.gz";
  fs::resize_file(broken, fs::file_size(broken) / 2);
  const fs::path out = dir / "out";
  const Outcome run = mpirun(
      2, "animate " + quote(frames.string()) + kAnimate + " --render " + quote(out.string()), dir);
  EXPECT_EQ(run.status, 1) << run.err;
  EXPECT_NE(run.err.find("horse-collapse-03.obj.gz"), std::string::npos) << run.err;
  std::size_t messages = 0;
  for (std::size_t at = 0; (at = run.err.find("splitray: ", at)) != std::string::npos; ++at)
    ++messages;
  EXPECT_EQ(messages, 1u) << "one message, from one rank:\n" << run.err;
  // Frames finished before the error may stay; every file left is a whole image.
  if (fs::exists(out))
    for (const auto& entry : fs::directory_iterator(out)) {
      EXPECT_EQ(entry.path().extension(), ".png") << entry.path() << " left behind";
      EXPECT_EQ(read_png(entry.path()).width, 96) << entry.path();
    }
  fs::remove_all(dir);
}

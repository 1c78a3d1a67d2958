// `splitray view` (issue 8): started under Xvfb on a small scene with a fixed camera, it shows
// frames, saves a screenshot that matches the headless `render --mode hybrid` of the same
// scene, size and camera, and exits cleanly; without a display it fails with a clear message.
// Skipped with a message when xvfb-run or the built splitray is absent.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "splitray/render/shapes.hpp"
#include "test_data.hpp"

namespace {

namespace fs = std::filesystem;
const std::string kBinary = SPLITRAY_BINARY_DIR "/apps/splitray/splitray";

using splitray::test::quote;
using splitray::test::read_text;
struct Result {
  int status = -1;  // exit code; 128 + signal when killed
  std::string output;
};

// Runs a shell command with stdout and stderr into one log.
Result run(const std::string& command, const fs::path& dir) {
  const fs::path log = dir / "log.txt";
  const int raw =
      std::system((command + " > " + quote(log.string()) + " 2>&1 < /dev/null").c_str());
  Result r;
  if (raw != -1 && WIFEXITED(raw))
    r.status = WEXITSTATUS(raw);
  else if (raw != -1 && WIFSIGNALED(raw))
    r.status = 128 + WTERMSIG(raw);
  r.output = read_text(log);
  return r;
}

void write_obj(const fs::path& path, const splitray::Mesh& mesh) {
  std::ofstream out(path);
  for (const auto& p : mesh.positions) out << "v " << p.x << ' ' << p.y << ' ' << p.z << '\n';
  for (const auto& f : mesh.faces)
    out << "f " << f[0] + 1 << ' ' << f[1] + 1 << ' ' << f[2] + 1 << '\n';
}

// The vendored horse on a floor beside a mirror sphere, a point and a directional light, and a
// fixed camera: every pass of the hybrid renderer has work.
fs::path write_scene(const fs::path& dir) {
  write_obj(dir / "floor.obj", splitray::make_quad({-3, 0, 3}, {6, 0, 0}, {0, 0, -6}));
  write_obj(dir / "sphere.obj", splitray::make_icosphere(3));
  const std::string horse = std::string(SPLITRAY_SOURCE_DIR) + "/data/horse/horse.obj.gz";
  std::ofstream(dir / "scene.json") << R"({
  "camera": {"eye": [0.6, 1.5, 3.6], "target": [0, 0.6, -0.2], "fov": 50},
  "background": [0.2, 0.25, 0.35],
  "materials": [
    {"name": "floor", "diffuse": [0.7, 0.7, 0.65]},
    {"name": "horse", "diffuse": [0.8, 0.5, 0.3], "specular": 0.3, "shininess": 40},
    {"name": "mirror", "diffuse": 0.05, "specular": 0.8, "shininess": 100, "reflectivity": 0.85}
  ],
  "instances": [
    {"mesh": "floor.obj", "material": "floor"},
    {"mesh": ")" + horse + R"(", "material": "horse",
     "transform": [{"translate": [-0.7, -0.006, -0.8]}]},
    {"mesh": "sphere.obj", "material": "mirror",
     "transform": [{"scale": 0.45}, {"translate": [0.9, 0.45, 0.4]}]}
  ],
  "lights": [
    {"type": "point", "position": [1.5, 4, 2.5], "intensity": 16},
    {"type": "directional", "direction": [-0.4, -1, -0.5], "color": 0.4}
  ]
})";
  return dir / "scene.json";
}

using splitray::test::Png;
using splitray::test::read_png;

double psnr(const Png& a, const Png& b) {
  double sum = 0;
  for (std::size_t i = 0; i < a.rgb.size(); ++i) {
    const double d = static_cast<double>(a.rgb[i]) - b.rgb[i];
    sum += d * d;
  }
  if (sum == 0) return INFINITY;
  return 10 * std::log10(255.0 * 255.0 / (sum / static_cast<double>(a.rgb.size())));
}

class ViewTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!fs::exists(kBinary)) GTEST_SKIP() << kBinary << " is not built";
    if (std::system("command -v xvfb-run > /dev/null 2>&1") != 0)
      GTEST_SKIP() << "xvfb-run is not installed (Debian: xvfb)";
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = splitray::test::temp_dir(std::string("view_") + info->name());
  }
  fs::path dir_;
};

TEST_F(ViewTest, ScreenshotMatchesHeadlessRender) {
  const fs::path scene = write_scene(dir_);
  const fs::path shot = dir_ / "view.png", headless = dir_ / "headless.png";
  const std::string size = " -W 160 -H 120 ";
  const Result view = run("xvfb-run -a " + quote(kBinary) + " view " + quote(scene.string()) +
                              size + "--exit-after 3 --screenshot " + quote(shot.string()),
                          dir_);
  const Result render = run(quote(kBinary) + " render " + quote(scene.string()) + size +
                                "--mode hybrid -o " + quote(headless.string()),
                            dir_);
  if (render.status != 0 && render.output.find("OpenGL") != std::string::npos)
    GTEST_SKIP() << "no usable headless OpenGL: " << render.output;
  ASSERT_EQ(view.status, 0) << view.output;  // a clean exit, no signal
  ASSERT_EQ(render.status, 0) << render.output;
  EXPECT_NE(view.output.find("saved"), std::string::npos) << view.output;
  const Png a = read_png(shot), b = read_png(headless);
  ASSERT_EQ(a.width, 160);
  ASSERT_EQ(a.height, 120);
  ASSERT_EQ(b.width, 160);
  ASSERT_EQ(b.height, 120);
  const double db = psnr(a, b);
  std::printf("viewer screenshot vs headless hybrid render: %.2f dB\n", db);
  EXPECT_GE(db, 40.0);
  // Not a blank frame: the picture has the floor, the horse and the sky in it.
  std::size_t distinct = 0;
  for (std::size_t i = 3; i < a.rgb.size(); i += 3)
    distinct +=
        a.rgb[i] != a.rgb[i - 3] || a.rgb[i + 1] != a.rgb[i - 2] || a.rgb[i + 2] != a.rgb[i - 1];
  EXPECT_GT(distinct, a.rgb.size() / 3 / 10);
}

TEST_F(ViewTest, SequentialWithoutRefinementStillRuns) {
  const fs::path scene = write_scene(dir_);
  const fs::path shot = dir_ / "view.png";
  const Result view =
      run("xvfb-run -a " + quote(kBinary) + " view " + quote(scene.string()) +
              " -W 96 -H 72 --sequential --no-refine --no-reflections --exit-after 2 "
              "--screenshot " +
              quote(shot.string()),
          dir_);
  ASSERT_EQ(view.status, 0) << view.output;
  EXPECT_EQ(read_png(shot).width, 96);
}

// --frames plays a real animation with predicted kd rebuilds every frame.
TEST_F(ViewTest, PlaysAnAnimationWithPredictedRebuilds) {
  SPLITRAY_REQUIRE_SHARED(first, "anim_horse_collapse/frames/horse-collapse-01.obj.gz");
  const std::string frames = fs::path(first).parent_path().string() + "/horse-collapse-%02d.obj.gz";
  const fs::path shot = dir_ / "view.png";
  const Result view = run("xvfb-run -a " + quote(kBinary) + " view --frames " + quote(frames) +
                              " -W 96 -H 72 --exit-after 4 --screenshot " + quote(shot.string()),
                          dir_);
  ASSERT_EQ(view.status, 0) << view.output;
  const Png png = read_png(shot);
  EXPECT_EQ(png.width, 96);
  EXPECT_EQ(png.height, 72);
}

TEST_F(ViewTest, NoDisplayIsAClearError) {
  const fs::path scene = write_scene(dir_);
  const Result view = run("env -u DISPLAY -u WAYLAND_DISPLAY " + quote(kBinary) + " view " +
                              quote(scene.string()) + " -W 64 -H 48 --exit-after 1",
                          dir_);
  EXPECT_EQ(view.status, 1) << view.output;  // an error, not a crash
  EXPECT_NE(view.output.find("splitray: view: cannot open a window"), std::string::npos)
      << view.output;
  EXPECT_NE(view.output.find("xvfb-run"), std::string::npos) << view.output;
}

}  // namespace

// BART scenes: the file's camera, lights and materials, as `render --mode hybrid` shows them,
// and --frames plays the scene along its camera path.
TEST_F(ViewTest, BartSceneWithItsCameraAndItsAnimation) {
  SPLITRAY_REQUIRE_SHARED(aff, "anim_bart_museum/aff/museum5.aff");
  const fs::path shot = dir_ / "view.png", headless = dir_ / "headless.png";
  const Result view = run("xvfb-run -a " + quote(kBinary) + " view " + quote(aff) +
                              " -W 160 -H 120 --exit-after 3 --screenshot " + quote(shot.string()),
                          dir_);
  const Result render = run(quote(kBinary) + " render " + quote(aff) +
                                " -W 160 -H 120 --mode hybrid -o " + quote(headless.string()),
                            dir_);
  if (render.status != 0 && render.output.find("OpenGL") != std::string::npos)
    GTEST_SKIP() << "no usable headless OpenGL: " << render.output;
  ASSERT_EQ(view.status, 0) << view.output;
  ASSERT_EQ(render.status, 0) << render.output;
  EXPECT_GE(psnr(read_png(shot), read_png(headless)), 40.0);
  const Result frames =
      run("xvfb-run -a " + quote(kBinary) + " view --frames " + quote(aff) +
              " -W 96 -H 72 --exit-after 3 --json --screenshot " + quote(shot.string()),
          dir_);
  ASSERT_EQ(frames.status, 0) << frames.output;
  EXPECT_EQ(read_png(shot).width, 96);
  EXPECT_NE(frames.output.find("\"frames_shown\": 3"), std::string::npos) << frames.output;
}

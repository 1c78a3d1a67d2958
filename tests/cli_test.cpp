// The splitray program end to end: help, usage and file errors (exit codes, messages that
// name the file, no crash, no partial output), kd against brute through `trace`, the keys of
// `build --json`, and PNG output of `render`.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "test_data.hpp"

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const std::string kBinary = SPLITRAY_BINARY_DIR "/apps/splitray/splitray";

struct Result {
  int status = -1;  // exit code; 128 + signal number when killed by a signal
  std::string out, err;
};

using splitray::test::quote;
using splitray::test::read_text;
// A fresh folder for the current test (tests run in parallel under ctest).
fs::path test_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  return splitray::test::temp_dir(std::string("cli_") + info->test_suite_name() + "_" +
                                  info->name());
}

// Runs `splitray ARGS` with stdout and stderr captured in files under `dir`.
Result run(const std::string& args, const fs::path& dir) {
  const fs::path out = dir / "stdout.txt", err = dir / "stderr.txt";
  const std::string command = quote(kBinary) + " " + args + " > " + quote(out.string()) + " 2> " +
                              quote(err.string()) + " < /dev/null";
  const int raw = std::system(command.c_str());
  Result result;
  if (raw != -1 && WIFEXITED(raw))
    result.status = WEXITSTATUS(raw);
  else if (raw != -1 && WIFSIGNALED(raw))
    result.status = 128 + WTERMSIG(raw);
  result.out = read_text(out);
  result.err = read_text(err);
  fs::remove(out);
  fs::remove(err);
  return result;
}

json run_json(const std::string& args, const fs::path& dir) {
  const Result result = run(args + " --json", dir);
  EXPECT_EQ(result.status, 0) << "splitray " << args << "\n" << result.err;
  try {
    return json::parse(result.out);  // exactly one object: trailing text throws
  } catch (const std::exception& e) {
    ADD_FAILURE() << "splitray " << args << " --json printed no single JSON object: " << e.what()
                  << "\n"
                  << result.out;
    return json::object();
  }
}

// Files left in `dir` other than the ones named in `keep`.
std::vector<std::string> leftovers(const fs::path& dir, const std::vector<std::string>& keep) {
  std::vector<std::string> names;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    const std::string name = fs::relative(entry.path(), dir).string();
    if (std::find(keep.begin(), keep.end(), name) == keep.end()) names.push_back(name);
  }
  return names;
}

std::string horse() { return splitray::test::vendored_file("horse/horse.obj.gz"); }

class Cli : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(kBinary)) << kBinary << " is missing: build the splitray target first";
    dir_ = test_dir();
  }
  Result run(const std::string& args) const { return ::run(args, dir_); }
  json run_json(const std::string& args) const { return ::run_json(args, dir_); }

  // A usage or file error: a clean exit (no signal) with a non-zero code and a message.
  void expect_failure(const std::string& args, const std::string& mentioned) const {
    const Result result = run(args);
    EXPECT_GT(result.status, 0) << "splitray " << args << " should fail";
    EXPECT_LT(result.status, 128) << "splitray " << args << " crashed\n" << result.err;
    EXPECT_NE(result.err.find(mentioned), std::string::npos)
        << "splitray " << args << ": the message should mention '" << mentioned << "':\n"
        << result.err;
  }

  fs::path dir_;
};

TEST_F(Cli, HelpForTheProgramAndEveryCommand) {
  const Result top = run("--help");
  EXPECT_EQ(top.status, 0) << top.err;
  for (const std::string command : {"render", "build", "trace", "knn", "bench"})
    EXPECT_NE(top.out.find(command), std::string::npos) << "--help does not list " << command;

  const std::vector<std::pair<std::string, std::vector<std::string>>> commands = {
      {"render",
       {"--output", "--width", "--height", "--camera", "--accel", "--builder", "--threads",
        "--max-depth", "--json"}},
      {"build", {"MESH", "--accel", "--builder", "--threads", "--kt", "--ki", "--bins", "--json"}},
      {"trace", {"MESH", "--accel", "--rays", "--kind", "--seed", "--camera", "--any", "--json"}},
      {"knn", {"INPUT", "--k", "--json"}},
      {"bench", {"build-trace"}},
      {"bench build-trace", {}},
      {"bench kd-costs", {"--kt", "--ki", "--builder", "--meshes", "--json"}},
  };
  for (const auto& [command, options] : commands) {
    const Result help = run(command + " --help");
    EXPECT_EQ(help.status, 0) << command << " --help\n" << help.err;
    for (const auto& option : options)
      EXPECT_NE(help.out.find(option), std::string::npos) << command << " --help lacks " << option;
  }
  const Result version = run("--version");
  EXPECT_EQ(version.status, 0);
  EXPECT_FALSE(version.out.empty());
}

TEST_F(Cli, UsageErrorsExitNonZeroWithAMessage) {
  expect_failure("", "subcommand");
  expect_failure("no-such-command", "no-such-command");
  expect_failure("render --no-such-option", "no-such-option");
  expect_failure("build", "MESH");
  expect_failure("trace " + quote(horse()) + " --rays lots", "lots");
  expect_failure("trace " + quote(horse()) + " --kind sideways", "sideways");
  expect_failure("trace " + quote(horse()) + " --camera 1,2,3", "camera");
  expect_failure("trace " + quote(horse()) + " --camera 0,0,5,0,0,0,abc", "abc");
  // Issue #23: an eye 1.85e19 from the target overflowed the camera's rays.
  expect_failure("render " + quote(horse()) + " --camera 1.85e19,0,0,0,0,0 -W 8 -H 8 -o " +
                     quote((dir_ / "far.png").string()),
                 "beyond the limit");
  expect_failure("build " + quote(horse()) + " --accel nope", "nope");
  expect_failure("render --width 0", "width");
  // A builder that the structure does not have is a splitray::Error: exit code 1.
  const Result builder = run("build " + quote(horse()) + " --accel kd --builder nope");
  EXPECT_EQ(builder.status, 1) << builder.err;
  EXPECT_EQ(builder.err.rfind("splitray: ", 0), 0u) << builder.err;
  EXPECT_NE(builder.err.find("nope"), std::string::npos) << builder.err;
}

TEST_F(Cli, MissingFileIsNamed) {
  const std::string missing = (dir_ / "no" / "such" / "mesh.obj").string();
  const std::vector<std::string> commands = {"build", "trace",
                                             "render -o " + quote((dir_ / "x.png").string())};
  for (const std::string& command : commands) {
    const Result result = run(command + " " + quote(missing));
    EXPECT_EQ(result.status, 1) << command << "\n" << result.err;
    EXPECT_EQ(result.err.rfind("splitray: ", 0), 0u) << result.err;
    EXPECT_NE(result.err.find(missing), std::string::npos) << result.err;
    EXPECT_TRUE(result.out.empty()) << result.out;
  }
  EXPECT_FALSE(fs::exists(dir_ / "x.png"));
}

// A machine without a usable OpenGL 4.5 (here Mesa told to offer 3.3 only) gets a clear error
// from the hybrid renderer, never a crash, and no output file.
TEST_F(Cli, HybridWithoutOpenGl45IsAClearError) {
  const fs::path png = dir_ / "hybrid.png";
  ::setenv("MESA_GL_VERSION_OVERRIDE", "3.3", 1);
  const Result result =
      run("render " + quote(horse()) + " --mode hybrid -W 32 -H 24 -o " + quote(png.string()));
  ::unsetenv("MESA_GL_VERSION_OVERRIDE");
  EXPECT_EQ(result.status, 1) << result.err;
  // The error is the last line (progress may report the steps that finished before it).
  const std::string error = "splitray: OpenGL (--mode hybrid): ";
  const std::size_t line = result.err.rfind('\n', result.err.size() - 2);
  EXPECT_EQ(result.err.compare(line == std::string::npos ? 0 : line + 1, error.size(), error), 0)
      << result.err;
  EXPECT_NE(result.err.find("no usable OpenGL 4.5"), std::string::npos) << result.err;
  EXPECT_FALSE(fs::exists(png));
}

TEST_F(Cli, HostileFilesFailCleanlyAndLeaveNoOutput) {
  const std::vector<std::pair<std::string, std::string>> files = {
      {"index_out_of_range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"},
      {"negative_index.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -7\n"},
      {"empty.obj", ""},
      {"no_faces.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"},
      {"not_gzip.obj.gz", "this is not gzip data at all\n"},
      {"truncated.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex 1000\nproperty float x\n"
       "property float y\nproperty float z\nelement face 2000\n"
       "property list uchar int vertex_indices\nend_header\n\x01\x02\x03"},
      {"scene_with_missing_mesh.json", R"({"meshes": [{"file": "nowhere.obj"}]})"},
      {"broken_scene.json", "{\"meshes\": [ "},
      // Issue #23: coordinates near +-3e38 crashed the BVH's traversal; a transform that moves
      // valid vertices past the limit.
      {"huge_coordinates.obj",
       "v -3e38 -3e38 0\nv 3e38 -3e38 0\nv 0 3e38 1e38\nv 1 2 3\nf 1 2 3\nf 1 2 4\n"},
      {"overflowing_transform.json",
       R"({"instances": [{"mesh": "tri.obj", "transform": [{"scale": 1e30}]}]})"},
  };
  std::vector<std::string> keep = {"tri.obj"};
  std::ofstream(dir_ / "tri.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  for (const auto& [name, content] : files) {
    std::ofstream(dir_ / name, std::ios::binary) << content;
    keep.push_back(name);
  }
  for (const auto& [name, content] : files) {
    const std::string path = (dir_ / name).string();
    const std::vector<std::string> commands = {
        "build " + quote(path) + " --accel brute",
        "trace " + quote(path) + " --accel bvh --rays 64",
        "render " + quote(path) + " -W 16 -H 16 -o " + quote((dir_ / "out.png").string())};
    for (const std::string& command : commands) {
      const Result result = run(command);
      EXPECT_EQ(result.status, 1) << command << " (status >= 128 means a crash)\n" << result.err;
      EXPECT_EQ(result.err.rfind("splitray: ", 0), 0u) << command << "\n" << result.err;
      // A scene naming a missing mesh may name either file.
      const bool named = result.err.find(name) != std::string::npos ||
                         (name == "scene_with_missing_mesh.json" &&
                          result.err.find("nowhere.obj") != std::string::npos);
      EXPECT_TRUE(named) << command << ": the message should name the file:\n" << result.err;
    }
  }
  EXPECT_EQ(leftovers(dir_, keep), std::vector<std::string>{});
}

TEST_F(Cli, RenderThatCannotWriteLeavesNoFile) {
  // The output folder does not exist.
  expect_failure("render " + quote(horse()) + " -W 16 -H 16 -o " +
                     quote((dir_ / "absent" / "out.png").string()),
                 "absent");
  // The output name is a folder.
  fs::create_directory(dir_ / "folder.png");
  expect_failure(
      "render " + quote(horse()) + " -W 16 -H 16 -o " + quote((dir_ / "folder.png").string()),
      "folder.png");
  // The output folder is a file.
  std::ofstream(dir_ / "file") << "x";
  expect_failure(
      "render " + quote(horse()) + " -W 16 -H 16 -o " + quote((dir_ / "file" / "out.png").string()),
      "file");
  EXPECT_EQ(leftovers(dir_, {"folder.png", "file"}), std::vector<std::string>{});
}

// The PNG signature and the IHDR chunk's width and height (big-endian).
void expect_png(const fs::path& path, int width, int height) {
  const std::string bytes = read_text(path);
  ASSERT_GE(bytes.size(), 33u) << path;
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << path;
  EXPECT_EQ(bytes.substr(12, 4), "IHDR") << path;
  const auto be32 = [&](std::size_t at) {
    std::uint32_t value = 0;
    for (std::size_t i = 0; i < 4; ++i)
      value = value << 8 | static_cast<unsigned char>(bytes[at + i]);
    return value;
  };
  EXPECT_EQ(be32(16), static_cast<std::uint32_t>(width));
  EXPECT_EQ(be32(20), static_cast<std::uint32_t>(height));
}

TEST_F(Cli, RenderWritesAPngOfTheRequestedSize) {
  const fs::path png = dir_ / "horse.png";
  const json summary =
      run_json("render " + quote(horse()) + " -W 64 -H 40 --max-depth 2 -o " + quote(png.string()));
  expect_png(png, 64, 40);
  for (const std::string key : {"scene", "output", "width", "height", "triangles", "accel",
                                "builder", "build_ms", "render_ms", "rays", "mrays_per_s"})
    EXPECT_TRUE(summary.contains(key)) << "render --json lacks " << key;
  EXPECT_EQ(summary.value("triangles", 0), 16843);
  EXPECT_GE(summary.value("rays", 0), 64 * 40);
  EXPECT_EQ(summary.value("output", ""), png.string());
  EXPECT_EQ(leftovers(dir_, {"horse.png"}), std::vector<std::string>{});

  // The readable summary names the output file.
  const fs::path png2 = dir_ / "horse2.png";
  const Result text = run("render " + quote(horse()) +
                          " -W 20 -H 10 --camera 0,0.2,3,0,0,0,40 -o " + quote(png2.string()));
  EXPECT_EQ(text.status, 0) << text.err;
  EXPECT_NE(text.out.find(png2.string()), std::string::npos) << text.out;
  expect_png(png2, 20, 10);
}

TEST_F(Cli, RenderOfTheDefaultScene) {
  const fs::path png = dir_ / "default.png";
  const Result result = run("render -W 48 -H 32 -o " + quote(png.string()));
  EXPECT_EQ(result.status, 0) << result.err;
  expect_png(png, 48, 32);
}

TEST_F(Cli, BuildJsonHasEveryKey) {
  for (const std::string accel : {"kd", "brute"}) {
    const json stats = run_json("build " + quote(horse()) + " --accel " + accel);
    for (const std::string key : {"prims", "build_ms", "sah_cost", "nodes", "leaves",
                                  "empty_leaves", "max_depth", "mean_leaf_depth", "mean_leaf_prims",
                                  "prim_refs", "bytes", "cost_evals", "accel", "builder"})
      EXPECT_TRUE(stats.contains(key)) << "build --accel " << accel << " --json lacks " << key;
    EXPECT_EQ(stats.value("prims", 0), 16843);
    EXPECT_EQ(stats.value("accel", ""), accel);
    EXPECT_GT(stats.value("bytes", 0), 0);
    EXPECT_GE(stats.value("nodes", 0), stats.value("leaves", 0));
  }
  const json kd = run_json("build " + quote(horse()) + " --accel kd");
  EXPECT_TRUE(kd["sah_cost"].is_number()) << "the kd-tree has an SAH cost";
  EXPECT_GT(kd.value("leaves", 0), 1);

  const Result table = run("build " + quote(horse()) + " --accel kd");
  EXPECT_EQ(table.status, 0) << table.err;
  EXPECT_NE(table.out.find("sah_cost"), std::string::npos) << table.out;
  EXPECT_NE(table.out.find("(K_T = 70, K_I = 20)"), std::string::npos) << table.out;
}

// The SAH cost names its constants: kd's own defaults, BIH's and BVH's 15 / 20, and --kt / --ki
// when given.
TEST_F(Cli, BuildReportsThePerStructureSahConstants) {
  for (const auto& [accel, kt] : {std::pair{"kd", 70}, {"bih", 15}, {"bvh", 15}}) {
    const json stats = run_json("build " + quote(horse()) + " --accel " + accel);
    EXPECT_EQ(stats["sah_kt"], kt) << accel;
    EXPECT_EQ(stats["sah_ki"], 20) << accel;
    const json given =
        run_json("build " + quote(horse()) + " --accel " + accel + " --kt 30 --ki 10");
    EXPECT_EQ(given["sah_kt"], 30) << accel;
    EXPECT_EQ(given["sah_ki"], 10) << accel;
  }
  const Result help = run("build --help");
  EXPECT_NE(help.out.find("default: kd 70"), std::string::npos) << help.out;
}

// `trace` with kd and brute prints identical hits, id_checksum and sum_t.
void expect_same_hits(const fs::path& dir, const std::string& mesh, const std::string& args) {
  SCOPED_TRACE(mesh + " " + args);
  const json kd = run_json("trace " + quote(mesh) + " --accel kd " + args, dir);
  const json brute = run_json("trace " + quote(mesh) + " --accel brute " + args, dir);
  EXPECT_GT(kd.value("hits", 0), 0);
  EXPECT_EQ(kd["hits"], brute["hits"]);
  EXPECT_EQ(kd["id_checksum"], brute["id_checksum"]);
  EXPECT_EQ(kd["sum_t"], brute["sum_t"]);  // the same triangle test: bit-identical t
  EXPECT_EQ(kd["rays"], brute["rays"]);
}

TEST_F(Cli, TraceKdEqualsBruteOnTheVendoredHorse) {
  const json primary =
      run_json("trace " + quote(horse()) + " --accel kd --kind primary --rays 20000");
  for (const std::string key :
       {"rays", "hits", "sum_t", "id_checksum", "ms", "mrays_per_s", "build_ms"})
    EXPECT_TRUE(primary.contains(key)) << "trace --json lacks " << key;
  EXPECT_EQ(primary.value("rays", 0), 20000);
  expect_same_hits(dir_, horse(), "--kind primary --rays 20000 --seed 3");
  expect_same_hits(dir_, horse(), "--kind random --rays 20000 --seed 4");
  expect_same_hits(dir_, horse(), "--kind diffuse --rays 2000 --seed 5");
  // Any hit: the same rays are occluded.
  const json kd_any =
      run_json("trace " + quote(horse()) + " --accel kd --kind random --rays 2000 --any");
  const json brute_any =
      run_json("trace " + quote(horse()) + " --accel brute --kind random --rays 2000 --any");
  EXPECT_GT(kd_any.value("hits", 0), 0);
  EXPECT_EQ(kd_any["hits"], brute_any["hits"]);
}

TEST_F(Cli, TraceKdEqualsBruteOnSharedMeshes) {
  SPLITRAY_REQUIRE_SHARED(cat, "static_sumner_cat_lion_poses/cat-poses/cat-01.obj.gz");
  expect_same_hits(dir_, cat, "--kind primary --rays 10000 --seed 1");
  expect_same_hits(dir_, cat, "--kind random --rays 10000 --seed 2");
  SPLITRAY_REQUIRE_SHARED(box, "static_cornell_box/cornell_box.obj");
  expect_same_hits(dir_, box, "--kind primary --rays 20000 --camera 278,273,-800,278,273,0,40");
  expect_same_hits(dir_, box, "--kind random --rays 20000");
  SPLITRAY_REQUIRE_SHARED(sibenik, "static_sibenik/sibenik.obj");
  // From inside the nave (the camera of ../shared/data/README.md).
  expect_same_hits(dir_, sibenik, "--kind primary --rays 2000 --camera=-17,-13.6,0,19,-9,0,60");
  expect_same_hits(dir_, sibenik, "--kind random --rays 2000");
}

TEST_F(Cli, TraceIsReproducibleAndIndependentOfThreads) {
  const std::string base = "trace " + quote(horse()) + " --accel kd --kind random --rays 20000";
  const json one = run_json(base + " --seed 9 --threads 1");
  const json two = run_json(base + " --seed 9 --threads 2");
  const json other = run_json(base + " --seed 10");
  EXPECT_EQ(one["hits"], two["hits"]);
  EXPECT_EQ(one["id_checksum"], two["id_checksum"]);
  EXPECT_EQ(one["sum_t"], two["sum_t"]);
  EXPECT_NE(one["id_checksum"], other["id_checksum"]) << "another seed should cast other rays";
}

// animate --compare: every strategy on the same frames, the frame-time keys, no hit differing
// from the kd rebuild's among our structures, and the kd run's frame-time keys.
TEST_F(Cli, AnimateComparesEveryStrategyOnTheSameFrames) {
  SPLITRAY_REQUIRE_SHARED(first, "anim_horse_collapse/frames/horse-collapse-01.obj.gz");
  const std::string frames =
      quote((fs::path(first).parent_path() / "horse-collapse-%02d.obj.gz").string());
  const fs::path csv = test_dir() / "compare.csv";
  const json all = run_json("animate " + frames +
                            " --frames 3 -t 2 --compare --pass-width 64 --pass-height 48 --csv " +
                            quote(csv.string()));
  EXPECT_EQ(all.value("frames", 0), 3);
  ASSERT_TRUE(all.contains("strategies"));
  for (const char* name : {"kd-coherent", "kd-rebuild", "bvh-refit", "bvh-rebuild", "embree-refit",
                           "embree-low", "embree-medium"}) {
    ASSERT_TRUE(all["strategies"].contains(name)) << name;
    const json& s = all["strategies"][name];
    for (const char* key : {"median_update_ms", "median_trace_ms", "median_frame_ms"})
      EXPECT_GT(s.value(key, 0.0), 0.0) << name << " " << key;
    EXPECT_GT(s.value("frame_ms_vs_best_embree", 0.0), 0.0) << name;
    if (s.value("exact", false)) {
      EXPECT_EQ(s.value("hit_mismatches", -1), 0) << name;
    }
  }
  // Per frame: update and trace times are positive and the frame time is their sum (the CSV
  // rounds each to 1e-4 ms); 7 strategies x 3 frames.
  std::istringstream rows(read_text(csv));
  std::string row;
  std::getline(rows, row);
  EXPECT_EQ(row.rfind("strategy,frame,update_ms,trace_ms,frame_ms,", 0), 0u) << row;
  std::size_t count = 0;
  while (std::getline(rows, row)) {
    std::istringstream cells(row);
    std::string strategy, frame, update, trace, total;
    std::getline(cells, strategy, ',');
    std::getline(cells, frame, ',');
    std::getline(cells, update, ',');
    std::getline(cells, trace, ',');
    std::getline(cells, total, ',');
    EXPECT_GT(std::stod(update), 0.0) << row;
    EXPECT_GT(std::stod(trace), 0.0) << row;
    EXPECT_NEAR(std::stod(total), std::stod(update) + std::stod(trace), 2e-4) << row;
    ++count;
  }
  EXPECT_EQ(count, 7u * 3u);
  const json kd =
      run_json("animate " + frames + " --frames 3 -t 1 --rays 0 --pass-width 64 --pass-height 48");
  for (const char* key : {"median_update_ms", "median_trace_ms", "median_frame_ms"})
    EXPECT_GT(kd.value(key, 0.0), 0.0) << key;
  ASSERT_TRUE(kd["coherent"].is_object());
  EXPECT_EQ(kd["coherent"]["frames"].size(), 3u);
}

// animate --accel bvh --refit on a real sequence: the kd run's summary keys, refitted trees
// that answer every ray as the rebuilt ones, and a results table that keeps the prose around it.
TEST_F(Cli, AnimateRefitsABvhOnHorseCollapse) {
  SPLITRAY_REQUIRE_SHARED(first, "anim_horse_collapse/frames/horse-collapse-01.obj.gz");
  const std::string frames =
      quote((fs::path(first).parent_path() / "horse-collapse-%02d.obj.gz").string());
  const std::string common = "animate " + frames + " --frames 4 --rays 3000 -t 1";
  const json kd = run_json(common + " --predictor kalman");
  const fs::path results = dir_ / "animate.json", md = dir_ / "animate.md";
  std::ofstream(md)
      << "# Prose before\n\n| sequence / predictor | old |\n|---|---|\n| x | 1 |\n\nafter\n";
  for (const char* builder : {"binned", "sbvh"}) {
    const json bvh = run_json(common + " --accel bvh --refit --builder " + builder + " --results " +
                              quote(results.string()));
    for (const auto& [key, value] : kd.items())
      EXPECT_TRUE(bvh.contains(key)) << "animate --refit lacks the summary key " << key;
    EXPECT_EQ(bvh.value("accel", ""), "bvh");
    EXPECT_EQ(bvh.value("predictor", ""), "refit");
    EXPECT_EQ(bvh.value("builder", ""), builder);
    EXPECT_EQ(bvh.value("frames", 0), 4);
    EXPECT_EQ(bvh.value("triangles", 0), 16843);
    EXPECT_EQ(bvh.value("hit_mismatches", -1), 0) << "refitted and rebuilt BVHs disagree";
    EXPECT_GT(bvh.value("mean_trace_ms_predicted", 0.0), 0.0);
    EXPECT_GT(bvh.value("sah_cost_ratio", 0.0), 0.0);
    EXPECT_TRUE(bvh["mean_prediction_error"].is_null());
  }
  const json all = json::parse(read_text(results));
  EXPECT_TRUE(all["runs"].contains("anim_horse_collapse/bvh-binned-refit"));
  EXPECT_TRUE(all["runs"].contains("anim_horse_collapse/bvh-sbvh-refit"));
  const std::string table = read_text(md);
  EXPECT_EQ(table.rfind("# Prose before\n", 0), 0u) << table;
  EXPECT_NE(table.find("\nafter\n"), std::string::npos) << table;
  EXPECT_NE(table.find("| anim_horse_collapse/bvh-sbvh-refit | 4 | 16843 |"), std::string::npos)
      << table;
  EXPECT_EQ(table.find("| x | 1 |"), std::string::npos) << "the old table should be replaced";

  expect_failure(common + " --accel kd --refit", "--refit");
  expect_failure(common + " --accel bvh", "--refit");
  expect_failure(common + " --accel bvh --refit --builder nope", "nope");
}

// bench kd-costs: one tree per K_T, the SAH's two sums rising and falling as they must (fewer,
// larger leaves: fewer node steps, more triangle tests), and a fit per ray kind.
TEST_F(Cli, KdCostsFitsStepsAndTestsPerTree) {
  const json report = run_json("bench kd-costs --quick --meshes horse");
  ASSERT_EQ(report["meshes"].size(), 1u);
  const json& trees = report["meshes"][0]["trees"];
  ASSERT_EQ(trees.size(), 3u);  // --quick: K_T 5, 15, 60
  for (std::size_t i = 1; i < trees.size(); ++i) {
    EXPECT_LT(trees[i]["nodes"], trees[i - 1]["nodes"]);
    EXPECT_LT(trees[i]["steps"], trees[i - 1]["steps"]);
    EXPECT_GT(trees[i]["tests"], trees[i - 1]["tests"]);
    EXPECT_GT(trees[i]["primary"].get<double>(), 0);
  }
  for (const char* kind : {"primary", "diffuse"})
    EXPECT_TRUE(report["meshes"][0]["fits"].contains(kind)) << kind;
  EXPECT_EQ(report["relative"].size(), 3u);
  expect_failure("bench kd-costs --quick --builder nope", "nope");
}

// --plot of bench build-trace and animate: a whole PNG (drawn by scripts/plot_*.py) and no
// other file left; an output folder that does not exist is refused before any work.
TEST_F(Cli, PlotsAreWholePngsAndLeaveNothingElse) {
  const fs::path png = dir_ / "build_trace.png";
  const Result bench =
      run("bench build-trace --quick --accels kd embree --runs 1 --rays 2048 "
          "--markdown " +
          quote((dir_ / "bt.md").string()) + " --plot " + quote(png.string()));
  ASSERT_EQ(bench.status, 0) << bench.err;
  const std::string bytes = read_text(png);
  ASSERT_GE(bytes.size(), 8u);
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(leftovers(dir_, {"build_trace.png", "bt.md"}), std::vector<std::string>{});
  expect_failure("bench build-trace --quick --plot " + quote((dir_ / "absent" / "x.png").string()),
                 "absent");

  SPLITRAY_REQUIRE_SHARED(first, "anim_horse_collapse/frames/horse-collapse-01.obj.gz");
  const std::string frames =
      quote((fs::path(first).parent_path() / "horse-collapse-%02d.obj.gz").string());
  const fs::path plot = dir_ / "animate.png";
  const Result animate =
      run("animate " + frames + " --frames 3 --rays 0 -t 1 --plot " + quote(plot.string()));
  ASSERT_EQ(animate.status, 0) << animate.err;
  EXPECT_EQ(read_text(plot).substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(leftovers(dir_, {"build_trace.png", "bt.md", "animate.png"}),
            std::vector<std::string>{});
}

}  // namespace

// The command line as users expect it (issue 22): one --json / --json-out rule on every
// command and benchmark, progress readable in logs, output formats by extension (an unknown
// one fails before any work and writes nothing), your own rays and queries in NumPy files
// giving what the library gives, the file's camera for BART scenes, and every defect the issue
// lists, each with its own test: animate --accel embree writing --csv/--plot/--render, bench
// neural's progress, bench hybrid --quick's notes, the training plot and epoch count, render
// --mode hybrid's renderer and ray rate, run-default.sh -o, "splitray: splitray view:", -V;
// the man page and the bash completion.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <vector>

#include "hybrid_bench.hpp"
#include "splitray/accel/accel.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/io/npy.hpp"
#include "splitray/query/neighbor_index.hpp"
#include "test_data.hpp"

namespace splitray {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using test::quote;
using test::read_text;

const std::string kBinary = SPLITRAY_BINARY_DIR "/apps/splitray/splitray";
const std::string kTrainer = SPLITRAY_BINARY_DIR "/train/splitray-train";

struct Result {
  int status = -1;
  std::string out, err;
};

class CliConsistency : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(kBinary)) << kBinary << " is missing";
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = test::temp_dir(std::string("cli22_") + info->name());
  }
  // `splitray ARGS` (or PROGRAM ARGS), stdout and stderr captured; `prefix` goes before it
  // (environment, cd).
  Result run(const std::string& args, const std::string& prefix = "",
             const std::string& program = kBinary) const {
    const fs::path out = dir_ / "stdout.txt", err = dir_ / "stderr.txt";
    const std::string command = prefix + quote(program) + " " + args + " > " + quote(out.string()) +
                                " 2> " + quote(err.string()) + " < /dev/null";
    const int raw = std::system(command.c_str());
    Result r;
    if (raw != -1 && WIFEXITED(raw)) r.status = WEXITSTATUS(raw);
    if (raw != -1 && WIFSIGNALED(raw)) r.status = 128 + WTERMSIG(raw);
    r.out = read_text(out);
    r.err = read_text(err);
    fs::remove(out);
    fs::remove(err);
    return r;
  }
  std::vector<std::string> files() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_)) names.push_back(e.path().filename());
    std::sort(names.begin(), names.end());
    return names;
  }
  std::string horse() const { return test::vendored_file("horse/horse.obj.gz"); }
  fs::path dir_;
};

bool has_numpy() { return std::system("/usr/bin/python3 -c 'import numpy' > /dev/null 2>&1") == 0; }

// ------------------------------------------------------------------------- one JSON rule

TEST_F(CliConsistency, EveryCommandHasJsonAndJsonOut) {
  std::vector<std::string> commands = {"render",
                                       "build",
                                       "trace",
                                       "knn",
                                       "animate",
                                       "view",
                                       "bench build-trace",
                                       "bench bvh",
                                       "bench knn",
                                       "bench hybrid",
                                       "bench neural"};
  if (fs::exists(kTrainer)) commands.push_back("train");  // splitray-train's own help
  for (const std::string& command : commands) {
    const Result help = run(command + " --help");
    ASSERT_EQ(help.status, 0) << command;
    EXPECT_NE(help.out.find("--json "), std::string::npos) << command << " has no --json flag";
    EXPECT_NE(help.out.find("--json-out"), std::string::npos) << command << " has no --json-out";
  }
}

TEST_F(CliConsistency, JsonPrintsAndJsonOutWritesTheSameObject) {
  const std::string file = (dir_ / "build.json").string();
  const Result both = run("build " + quote(horse()) + " --json --json-out " + quote(file));
  ASSERT_EQ(both.status, 0) << both.err;
  const json printed = json::parse(both.out), written = json::parse(read_text(file));
  EXPECT_EQ(printed, written);
  EXPECT_EQ(printed["prims"], 16843);
  // --json-out alone: the table on stdout, the JSON in the file.
  const Result table = run("trace " + quote(horse()) + " -n 1000 --json-out " + quote(file));
  ASSERT_EQ(table.status, 0) << table.err;
  EXPECT_FALSE(json::accept(table.out));
  EXPECT_EQ(json::parse(read_text(file))["rays"], 1000);
}

// ------------------------------------------------------------------------------- progress

TEST_F(CliConsistency, ProgressInALogIsOneLinePerStep) {
  const Result r = run("render -W 64 -H 48 -o " + quote((dir_ / "p.png").string()));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err.find('\r'), std::string::npos) << "a bar drawn into a log:\n" << r.err;
  EXPECT_NE(r.err.find("render: 100%"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("generating the default scene ... done"), std::string::npos) << r.err;
  for (std::size_t at = 0; (at = r.err.find('\n', at)) != std::string::npos; ++at)
    EXPECT_TRUE(at + 1 == r.err.size() || r.err.compare(at + 1, 7, "render:") == 0) << r.err;
}

// -------------------------------------------------------------------------- image formats

TEST_F(CliConsistency, OutputFormatByExtensionAndUnknownOnesFailBeforeAnyWork) {
  for (const char* name : {"a.png", "a.exr", "a.pfm"}) {
    const Result r =
        run("render " + quote(horse()) + " -W 32 -H 24 -o " + quote((dir_ / name).string()));
    EXPECT_EQ(r.status, 0) << name << "\n" << r.err;
  }
  EXPECT_EQ(read_text(dir_ / "a.exr").substr(0, 4), std::string("\x76\x2f\x31\x01", 4));
  EXPECT_EQ(read_text(dir_ / "a.pfm").substr(0, 3), "PF\n");
  const Result jpg = run("render " + quote(horse()) + " -o " + quote((dir_ / "b.jpg").string()));
  EXPECT_EQ(jpg.status, 1);
  EXPECT_EQ(jpg.err.rfind("splitray: ", 0), 0u) << jpg.err;
  EXPECT_NE(jpg.err.find("unknown image format '.jpg'"), std::string::npos) << jpg.err;
  EXPECT_EQ(jpg.err.find("render:"), std::string::npos) << "work started:\n" << jpg.err;
  EXPECT_EQ(files(), (std::vector<std::string>{"a.exr", "a.pfm", "a.png"}));
}

// ------------------------------------------------------------ your own rays and queries

TEST_F(CliConsistency, NpyRaysGiveTheLibrarysHits) {
  if (!has_numpy()) GTEST_SKIP() << "/usr/bin/python3 with numpy is absent";
  const Mesh mesh = load_mesh(horse());
  const std::vector<Triangle> triangles = mesh.triangles();
  const Aabb box = mesh.bounds();
  std::mt19937 random(7);
  std::uniform_real_distribution<float> unit(-1, 1);
  std::vector<Ray> rays(2000);
  std::vector<float> values;
  for (Ray& r : rays) {
    r.org = box.center() + Vec3{unit(random), unit(random), unit(random)} * 0.6f;
    r.dir = Vec3{unit(random), unit(random), unit(random)} * 3.0f;  // not unit length
    values.insert(values.end(), {r.org.x, r.org.y, r.org.z, r.dir.x, r.dir.y, r.dir.z});
  }
  // Our .npy, turned by numpy into float64 in Fortran order (its writer, our reader).
  const fs::path ours = dir_ / "ours.npz", numpy = dir_ / "rays.npy", hits = dir_ / "hits.npz";
  write_npz(ours.string(), {{"rays", npy_array({rays.size(), 6}, values)}});
  const std::string convert =
      "/usr/bin/python3 -c \"import numpy as np, sys; r = np.load(sys.argv[1])['rays']; "
      "assert r.dtype == np.float32 and r.shape == (2000, 6); "
      "np.save(sys.argv[2], np.asfortranarray(r.astype(np.float64)))\" " +
      quote(ours.string()) + " " + quote(numpy.string());
  ASSERT_EQ(std::system(convert.c_str()), 0);
  const Result r = run("trace " + quote(horse()) + " --rays-in " + quote(numpy.string()) +
                       " --hits-out " + quote(hits.string()) + " --json");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(json::parse(r.out)["rays"], 2000);

  const auto accel = make_accel("brute", triangles);
  const auto arrays = read_npz(hits.string());
  std::map<std::string, NpyArray> by_name(arrays.begin(), arrays.end());
  ASSERT_EQ(by_name.at("t_hit").descr, "<f4");
  ASSERT_EQ(by_name.at("primitive_ids").descr, "<u4");
  ASSERT_EQ(by_name.at("primitive_uvs").shape, (std::vector<std::size_t>{2000, 2}));
  ASSERT_EQ(by_name.at("primitive_normals").shape, (std::vector<std::size_t>{2000, 3}));
  const auto* t = reinterpret_cast<const float*>(by_name["t_hit"].bytes.data());
  const auto* ids = reinterpret_cast<const std::uint32_t*>(by_name["primitive_ids"].bytes.data());
  const auto* uv = reinterpret_cast<const float*>(by_name["primitive_uvs"].bytes.data());
  const auto* n = reinterpret_cast<const float*>(by_name["primitive_normals"].bytes.data());
  std::size_t found = 0;
  for (std::size_t i = 0; i < rays.size(); ++i) {
    const Hit h = accel->intersect(rays[i]);
    found += h.found();
    ASSERT_EQ(ids[i], h.prim) << i;
    ASSERT_EQ(t[i], h.found() ? h.t : kInfinity) << i;  // bit-identical
    ASSERT_EQ(uv[2 * i], h.u);
    ASSERT_EQ(uv[2 * i + 1], h.v);
    const Vec3 normal = h.found() ? normalize(triangles[h.prim].geometric_normal()) : Vec3{0};
    ASSERT_EQ(n[3 * i + 2], normal.z);
  }
  EXPECT_GT(found, 100u);
  EXPECT_LT(found, rays.size());  // hits and misses
  // numpy reads the answer with Open3D's names and types.
  const std::string check =
      "/usr/bin/python3 -c \"import numpy as np, sys; h = np.load(sys.argv[1]); "
      "assert h['primitive_ids'].dtype == np.uint32 and h['t_hit'].dtype == np.float32; "
      "m = np.isinf(h['t_hit']); assert (h['primitive_ids'][m] == 2**32 - 1).all()\" " +
      quote(hits.string());
  EXPECT_EQ(std::system(check.c_str()), 0);
}

TEST_F(CliConsistency, NpyQueriesGiveTheLibrarysNeighbours) {
  if (!has_numpy()) GTEST_SKIP() << "/usr/bin/python3 with numpy is absent";
  const fs::path points = dir_ / "points.npy", queries = dir_ / "q.npy", out = dir_ / "nn.npz";
  const std::string make =
      "/usr/bin/python3 -c \"import numpy as np, sys; g = np.random.default_rng(3); "
      "np.save(sys.argv[1], g.uniform(-1, 1, (500, 3))); "
      "np.save(sys.argv[2], g.uniform(-1, 1, (40, 3)).astype(np.float32))\" " +
      quote(points.string()) + " " + quote(queries.string());
  ASSERT_EQ(std::system(make.c_str()), 0);
  const Result r = run("knn " + quote(points.string()) + " --queries-in " +
                       quote(queries.string()) + " --out " + quote(out.string()) + " --k 4");
  ASSERT_EQ(r.status, 0) << r.err;
  const FloatArray p = read_npy_floats(points.string()), q = read_npy_floats(queries.string());
  std::vector<Vec3> pv, qv;
  for (std::size_t i = 0; i < p.values.size(); i += 3)
    pv.push_back({p.values[i], p.values[i + 1], p.values[i + 2]});
  for (std::size_t i = 0; i < q.values.size(); i += 3)
    qv.push_back({q.values[i], q.values[i + 1], q.values[i + 2]});
  NeighborIndexConfig brute;
  brute.builder = "brute";
  const KnnResult expected = make_neighbor_index(pv, brute)->knn(qv, 4);
  const auto arrays = read_npz(out.string());
  std::map<std::string, NpyArray> by_name(arrays.begin(), arrays.end());
  ASSERT_EQ(by_name.at("indices").descr, "<i8");
  ASSERT_EQ(by_name.at("indices").shape, (std::vector<std::size_t>{40, 4}));
  const auto* idx = reinterpret_cast<const std::int64_t*>(by_name["indices"].bytes.data());
  const auto* dist = reinterpret_cast<const float*>(by_name["distances"].bytes.data());
  for (std::size_t i = 0; i < 40 * 4; ++i) {
    EXPECT_EQ(idx[i], expected.indices[i]);
    EXPECT_EQ(dist[i], expected.distances[i]);
  }
  // More neighbours asked than points exist: -1 and inf pad the rows.
  ASSERT_EQ(run("knn " + quote(points.string()) + " --queries-in " + quote(queries.string()) +
                " --out " + quote(out.string()) + " --k 502")
                .status,
            0);
  const auto padded = read_npz(out.string());
  const auto* row = reinterpret_cast<const std::int64_t*>(padded[0].second.bytes.data());
  EXPECT_GE(row[499], 0);  // 500 points: the rest of the 502 are padding
  EXPECT_EQ(row[500], -1);
  EXPECT_EQ(row[501], -1);
}

// ------------------------------------------------------------------------- BART scenes

TEST_F(CliConsistency, AnimateRenderOfABartSceneFollowsItsCameraPath) {
  SPLITRAY_REQUIRE_SHARED(aff, "anim_bart_museum/aff/museum5.aff");
  const Result r = run("animate " + quote(aff) + " --frames 2 --rays 0 -t 2 --render " +
                       quote((dir_ / "frames").string()) + " --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string a = read_text(dir_ / "frames/frame-0000.png"),
                    b = read_text(dir_ / "frames/frame-0001.png");
  ASSERT_GT(a.size(), 1000u);
  EXPECT_NE(a, b);  // frame 1 is seen from further along the path
  // Frame 0 is `render` of the scene (its camera at the animation's start), pixel for pixel.
  ASSERT_EQ(
      run("render " + quote(aff) + " -W 640 -H 480 -o " + quote((dir_ / "r.png").string())).status,
      0);
  EXPECT_EQ(read_text(dir_ / "r.png"), a);
}

// --------------------------------------------------------------------- the listed defects

TEST_F(CliConsistency, AnimateWithEmbreeWritesCsvPlotAndFrames) {
  SPLITRAY_REQUIRE_SHARED(first, "anim_horse_collapse/frames/horse-collapse-01.obj.gz");
  const std::string frames =
      quote((fs::path(first).parent_path() / "horse-collapse-%02d.obj.gz").string());
  const Result r =
      run("animate " + frames +
          " --accel embree --builder refit --frames 3 --rays 2048 "
          "--csv " +
          quote((dir_ / "e.csv").string()) + " --plot " + quote((dir_ / "e.png").string()) +
          " --render " + quote((dir_ / "f").string()));
  ASSERT_EQ(r.status, 0) << r.err;
  const std::string csv = read_text(dir_ / "e.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 4) << csv;  // header + 3 frames
  EXPECT_NE(csv.find("embree-refit"), std::string::npos);
  EXPECT_EQ(read_text(dir_ / "e.png").substr(1, 3), "PNG");
  for (const char* f : {"f/frame-0000.png", "f/frame-0001.png", "f/frame-0002.png"})
    EXPECT_TRUE(fs::exists(dir_ / f)) << f;
}

TEST_F(CliConsistency, BenchNeuralProgressIsTextNotJson) {
  const Result r =
      run("bench neural --quick --json",
          "SPLITRAY_MODEL_DIR=" + quote((test::source_dir() / "models").string()) + " ");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err.find("{\""), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("speed x"), std::string::npos) << r.err;
  EXPECT_TRUE(json::accept(r.out));  // stdout: the report alone
}

// bench bvh on a mesh given with its camera: one row per structure and thread count, ratios
// to Embree, our two BVHs agreeing on every ray, the per-ray profile; a bad camera is an error
// naming the entry.
TEST_F(CliConsistency, BenchBvhMeasuresAGivenMeshFromItsCamera) {
  const std::string mesh = horse() + "@0.5,0.3,2,0,0.2,0,50";
  const Result r = run("bench bvh --meshes " + quote(mesh) +
                       " --threads 1 --runs 1 --rays 4096 --views 2 --json");
  ASSERT_EQ(r.status, 0) << r.err;
  const json report = json::parse(r.out);
  const json& m = report["meshes"][0];
  EXPECT_EQ(m["triangles"], 16843);
  EXPECT_EQ(m["views"].size(), 2u);
  // bvh binned, sbvh; embree low, medium, high, medium-robust
  EXPECT_EQ(m["runs"][0]["results"].size(), 6u);
  EXPECT_EQ(m["runs"][0]["binned_vs_sbvh_differing"]["primary"], 0);
  EXPECT_GT(m["runs"][0]["ratios"]["sbvh"]["diffuse"]["batched"].get<double>(), 0.0);
  EXPECT_EQ(m["runs"][0]["ratios_robust"]["binned"]["against"], "embree medium-robust");
  EXPECT_GT(m["runs"][0]["ratios_robust"]["sbvh"]["primary"]["single"].get<double>(), 0.0);
  EXPECT_GT(m["profile"][0]["diffuse"]["nodes_per_ray"].get<double>(), 0.0);
  const Result bad = run("bench bvh --meshes " + quote(horse() + "@1,2,3") + " --json");
  EXPECT_EQ(bad.status, 1);
  EXPECT_NE(bad.err.find("--meshes"), std::string::npos) << bad.err;
}

// The benchmark scene's notes (bench/hybrid_bench.cpp) without running the benchmark: --quick
// says it chose the vendored meshes, and only missing data is called absent.
TEST_F(CliConsistency, BenchHybridQuickDoesNotCallPresentDataAbsent) {
  std::vector<std::string> notes;
  bench::hybrid_bench_scene(true, notes);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_EQ(notes[0].find("absent"), std::string::npos) << notes[0];
  EXPECT_NE(notes[0].find("--quick"), std::string::npos) << notes[0];
  SPLITRAY_REQUIRE_SHARED(cat, "static_sumner_cat_lion_poses/cat-poses/cat-01.obj.gz");
  notes.clear();
  bench::hybrid_bench_scene(false, notes);
  for (const std::string& note : notes) EXPECT_EQ(note.find("absent"), std::string::npos) << note;
}

TEST_F(CliConsistency, RenderHybridNamesItsRendererAndRatesTheCpusRays) {
  const Result r = run("render " + quote(horse()) + " --mode hybrid -W 96 -H 72 -o " +
                       quote((dir_ / "h.png").string()) + " --json");
  if (r.status != 0 && r.err.find("OpenGL") != std::string::npos)
    GTEST_SKIP() << "no usable headless OpenGL: " << r.err;
  ASSERT_EQ(r.status, 0) << r.err;
  const json j = json::parse(r.out);
  EXPECT_FALSE(j["gl_renderer"].get<std::string>().empty());
  const double expected = j["rays"].get<double>() / (j["cpu_ms"].get<double>() * 1e3);
  EXPECT_NEAR(j["mrays_per_s"].get<double>(), expected, 1e-9 + 1e-9 * expected);
  EXPECT_LE(j["cpu_ms"].get<double>(), j["render_ms"].get<double>());
}

TEST_F(CliConsistency, RunDefaultTakesAnOutputFile) {
  const std::string script = (test::source_dir() / "scripts/run-default.sh").string();
  const std::string env =
      "cd " + quote(dir_.string()) +
      " && SPLITRAY_NO_SETUP=1 SPLITRAY_BUILD_DIR=" + quote(SPLITRAY_BINARY_DIR) + " ";
  const Result r = run(quote(script) + " -o mine.png -W 48 -H 36", env, "bash");
  EXPECT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(fs::exists(dir_ / "mine.png")) << "relative to the folder it was run from";
  EXPECT_FALSE(fs::exists(dir_ / "splitray.png"));
}

TEST_F(CliConsistency, ErrorsNameTheCommandOnce) {
  const Result r =
      run("view --exit-after 1 " + quote(horse()), "env -u DISPLAY -u WAYLAND_DISPLAY ");
  ASSERT_EQ(r.status, 1) << r.err;
  EXPECT_EQ(r.err.rfind("splitray: view: ", 0), 0u) << r.err;
  EXPECT_EQ(r.err.find("splitray: splitray"), std::string::npos) << r.err;
}

TEST_F(CliConsistency, VersionFlags) {
  for (const char* flag : {"-V", "--version"}) {
    const Result r = run(flag);
    EXPECT_EQ(r.status, 0) << flag << ": " << r.err;
    EXPECT_EQ(r.out.rfind("splitray 0.", 0), 0u) << flag << ": " << r.out;
  }
}

TEST_F(CliConsistency, TrainingPrintsTheEpochsAskedAndPlotsWithAxes) {
  if (!fs::exists(kTrainer)) GTEST_SKIP() << "splitray-train is not built (no libtorch)";
  const Result r =
      run("--cost vvh --depth 1 --samples 64 --train-samples 32 --pool 2000 --tree-depth 1 "
          "--lookahead 0 --rotations 0 --eval-sets 1 --epochs 2 --threads 1 --data " +
              quote(horse()) + " --out " + quote((dir_ / "m.bin").string()),
          "", kTrainer);
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_NE(r.err.find("epoch 1/2"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("epoch 2/2"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("epoch 3"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("epoch 0"), std::string::npos) << r.err;
  // The plot is matplotlib's figure (8 x 5 inches at 100 dpi), not a bare curve.
  const std::string png = read_text(dir_ / "m.loss.png");
  ASSERT_GE(png.size(), 24u);
  const auto be32 = [&](std::size_t at) {
    return (static_cast<unsigned char>(png[at]) << 24) |
           (static_cast<unsigned char>(png[at + 1]) << 16) |
           (static_cast<unsigned char>(png[at + 2]) << 8) | static_cast<unsigned char>(png[at + 3]);
  };
  EXPECT_EQ(be32(16), 800);
  EXPECT_EQ(be32(20), 500);
}

// --------------------------------------------------------------- man page and completion

TEST_F(CliConsistency, ManPageAndBashCompletionAreBuilt) {
  const std::string man = read_text(SPLITRAY_BINARY_DIR "/apps/splitray/splitray.1");
  ASSERT_FALSE(man.empty()) << "no man page (help2man missing?)";
  EXPECT_NE(man.find(".TH SPLITRAY"), std::string::npos);
  EXPECT_NE(man.find("render"), std::string::npos);
  const std::string completion = SPLITRAY_BINARY_DIR "/apps/splitray/splitray.bash";
  const std::string probe =
      "bash -c " + quote("source " + quote(completion) +
                         "; COMP_WORDS=(splitray ren); COMP_CWORD=1; _splitray; "
                         "echo ${COMPREPLY[@]}; COMP_WORDS=(splitray trace m --rays-i); "
                         "COMP_CWORD=3; _splitray; echo ${COMPREPLY[@]}");
  const fs::path out = dir_ / "completion.txt";
  ASSERT_EQ(std::system((probe + " > " + quote(out.string())).c_str()), 0);
  EXPECT_EQ(read_text(out), "render\n--rays-in\n");
}

}  // namespace
}  // namespace splitray

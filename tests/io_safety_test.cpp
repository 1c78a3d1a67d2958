// The library's side of issue #23: readers take regular files only (a FIFO must not block),
// writers never replace an input, a link, a FIFO or a device and leave no temporary file;
// AFF include limits; formats detected from the content; small undefined behaviours.
// The command line's side is the table of hostile_files_test (tests/hostile_files/table.txt).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "splitray/core/errors.hpp"
#include "splitray/core/output_file.hpp"
#include "splitray/io/aff.hpp"
#include "splitray/io/format_checks.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/io/read_file.hpp"
#include "test_data.hpp"

namespace fs = std::filesystem;

namespace splitray {
namespace {

fs::path test_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  return test::temp_dir(std::string("io_safety_") + info->test_suite_name() + "_" + info->name());
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

// The message of the Error `f` throws ("" when it throws none).
template <typename F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::size_t entries(const fs::path& dir) {
  return static_cast<std::size_t>(
      std::distance(fs::directory_iterator(dir), fs::directory_iterator{}));
}

TEST(ReadFile, RefusesFifoWithoutBlocking) {
  const fs::path dir = test_dir();
  const fs::path fifo = dir / "points.xyz";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0644), 0);
  // Without O_NONBLOCK the open would wait for a writer forever.
  const std::string message = error_of([&] { read_file(fifo.string()); });
  EXPECT_NE(message.find("points.xyz: is not a regular file (it is a FIFO)"), std::string::npos)
      << message;
  EXPECT_NE(error_of([&] { read_file_head(fifo.string(), 100); }).find("FIFO"), std::string::npos);
}

TEST(ReadFile, RefusesDevicesAndFolders) {
  EXPECT_NE(error_of([] { read_file("/dev/zero"); }).find("/dev/zero: is not a regular file"),
            std::string::npos);
  const fs::path dir = test_dir();
  EXPECT_NE(error_of([&] { read_file(dir.string()); }).find("is a directory"), std::string::npos);
  EXPECT_NE(error_of([&] { read_file((dir / "absent.obj").string()); }).find("no such file"),
            std::string::npos);
}

TEST(OutputFile, NeverReplacesAnInputEvenThroughAHardLinkOrAnotherSpelling) {
  const fs::path dir = test_dir();
  const fs::path input = dir / "input.obj";
  write_text(input, "v 0 0 0\n");
  read_file(input.string());  // noted as an input
  fs::create_hard_link(input, dir / "hard.png");
  for (const fs::path& out : {input, dir / "." / "input.obj", dir / "hard.png"}) {
    const std::string message = error_of([&] { write_file_atomically(out.string(), "x"); });
    EXPECT_NE(message.find("the output is the same file as the input"), std::string::npos)
        << out << ": " << message;
  }
  EXPECT_EQ(test::read_text(input), "v 0 0 0\n");
  EXPECT_EQ(entries(dir), 2u);  // no temporary file left
}

TEST(OutputFile, RefusesLinksFifosDevicesAndFoldersAndNamesTheOption) {
  const fs::path dir = test_dir();
  write_text(dir / "target.txt", "keep");
  fs::create_symlink("target.txt", dir / "link.json");
  fs::create_symlink("nowhere.txt", dir / "dangling.json");
  ASSERT_EQ(::mkfifo((dir / "fifo.json").c_str(), 0644), 0);
  fs::create_directory(dir / "folder.json");
  note_output_option((dir / "link.json").string(), "--json-out");
  const struct {
    fs::path path;
    std::string want;
  } cases[] = {{dir / "link.json", "--json-out " + (dir / "link.json").string() +
                                       ": the output exists and is a symbolic link"},
               {dir / "dangling.json", "is a symbolic link"},
               {dir / "fifo.json", "is a FIFO"},
               {dir / "folder.json", "is a folder"},
               {"/dev/full", "/dev/full: the output exists and is a device"}};
  for (const auto& c : cases) {
    const std::string message = error_of([&] { write_file_atomically(c.path.string(), "x"); });
    EXPECT_NE(message.find(c.want), std::string::npos) << c.path << ": " << message;
  }
  EXPECT_EQ(test::read_text(dir / "target.txt"), "keep");
  EXPECT_EQ(entries(dir), 5u);  // no temporary file left
  // A regular file that is no input is replaced.
  write_text(dir / "old.json", "old");
  write_file_atomically((dir / "old.json").string(), "new");
  EXPECT_EQ(test::read_text(dir / "old.json"), "new");
  EXPECT_EQ(entries(dir), 6u);
}

TEST(OutputFile, APreviousOutputMayBeWrittenAgain) {
  // animate --resume reads the frames of an earlier run and renders a broken one again.
  const fs::path dir = test_dir();
  const fs::path frame = dir / "frame_0001.png";
  write_text(frame, "cut short");
  read_previous_output(frame.string());
  write_file_atomically(frame.string(), "whole");
  EXPECT_EQ(test::read_text(frame), "whole");
}

TEST(OutputFile, FailedWriteLeavesNoTemporary) {
  const fs::path dir = test_dir();
  {
    TemporaryFile tmp((dir / "out.bin").string());
    tmp.write("partial");
    EXPECT_TRUE(fs::exists(tmp.name()));
  }  // destroyed without commit: an error happened
  EXPECT_EQ(entries(dir), 0u);
  EXPECT_NE(error_of([&] {
              write_file_atomically((dir / "no" / "out.bin").string(), "x");
            }).find("cannot write the file"),
            std::string::npos);
}

// The message of loading the AFF scene `name` of `dir`.
std::string aff_error(const fs::path& dir, const std::string& name) {
  return error_of([&] { AffScene::load((dir / name).string()); });
}

TEST(Aff, DeepBlocksAreALimitNotAStackOverflow) {
  const fs::path dir = test_dir();
  std::string text;
  for (int i = 0; i < 1'000'000; ++i) text += "x a {\n";
  write_text(dir / "deep.aff", text);
  const std::string message = aff_error(dir, "deep.aff");
  EXPECT_NE(message.find("deep.aff:257: transform blocks nested deeper than the limit of 256"),
            std::string::npos)
      << message;
}

TEST(Aff, IncludesStayInTheSceneFolderAndAreNotQuoted) {
  const fs::path dir = test_dir();
  fs::create_directories(dir / "scene");
  write_text(dir / "secret.txt", "TOPSECRET password\n");
  write_text(dir / "scene" / "secret.txt", "TOPSECRET password\n");
  fs::create_symlink("../secret.txt", dir / "scene" / "link.aff");
  write_text(dir / "scene" / "up.aff", "i 0 ../secret.txt\n");
  write_text(dir / "scene" / "absolute.aff", "i 0 " + (dir / "secret.txt").string() + "\n");
  write_text(dir / "scene" / "link_in.aff", "i 0 link.aff\n");
  write_text(dir / "scene" / "inside.aff", "i 0 secret.txt\n");
  for (const char* name : {"up.aff", "absolute.aff", "link_in.aff"}) {
    const std::string message = aff_error(dir / "scene", name);
    EXPECT_NE(message.find(std::string(name) + ":1: the include '"), std::string::npos) << message;
    EXPECT_NE(message.find("lies outside the scene's folder"), std::string::npos) << message;
  }
  // A file inside the folder that is no AFF: the error names it but shows none of it.
  const std::string message = aff_error(dir / "scene", "inside.aff");
  EXPECT_NE(message.find("secret.txt:1: unknown statement a word (not shown"), std::string::npos)
      << message;
  EXPECT_EQ(message.find("TOPSECRET"), std::string::npos) << message;
}

// A material may not make the loader read an image elsewhere on the machine: a texture outside
// the model's folder (by "..", an absolute path or a link out) is not read, a warning says so,
// and MeshLoadOptions::references_root widens the rule.
TEST(MeshLoad, TexturesStayInTheModelFolder) {
  const fs::path dir = test_dir();
  fs::create_directories(dir / "model");
  fs::copy_file(test::vendored_file("spider/engineflare1.png"), dir / "outside.png");
  fs::copy_file(test::vendored_file("spider/engineflare1.png"), dir / "model" / "inside.png");
  fs::create_symlink("../outside.png", dir / "model" / "link.png");
  const std::string triangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n";
  const auto load = [&](const std::string& texture, const std::string& root) {
    write_text(dir / "model" / "m.mtl", "newmtl t\nmap_Kd " + texture + "\n");
    write_text(dir / "model" / "m.obj", "mtllib m.mtl\n" + triangle + "usemtl t\nf 1/1 2/2 3/3\n");
    std::vector<std::string> warnings;
    MeshLoadOptions options;
    options.materials = true;
    options.warnings = &warnings;
    options.references_root = root;
    const Mesh mesh = load_mesh((dir / "model" / "m.obj").string(), options);
    return std::pair{mesh.materials.at(0).diffuse_texture != nullptr, warnings};
  };
  EXPECT_TRUE(load("inside.png", "").first);
  for (const std::string& texture :
       {std::string("../outside.png"), (dir / "outside.png").string(), std::string("link.png")}) {
    const auto [textured, warnings] = load(texture, "");
    EXPECT_FALSE(textured) << texture;
    ASSERT_EQ(warnings.size(), 1u) << texture;
    EXPECT_NE(warnings[0].find("lies outside the folder of the model; refusing to read it"),
              std::string::npos)
        << warnings[0];
    EXPECT_NE(warnings[0].find("m.obj"), std::string::npos) << warnings[0];
    EXPECT_TRUE(load(texture, dir.string()).first) << texture;  // a wider root reads it
  }
}

TEST(DetectFormat, TheFixturesShowTheirOwnFormats) {
  const fs::path fixtures = test::source_dir() / "tests" / "fixtures";
  const struct {
    const char* file;
    const char* format;
  } cases[] = {{"cube.obj", ""},
               {"polygons.obj", ""},
               {"cube.off", "off"},
               {"cube_ascii.ply", "ply"},
               {"cube_binary.ply", "ply"},
               {"cube_binary_be.ply", "ply"},
               {"cube_ascii.stl", "stl"},
               {"cube_binary.stl", "stl"},
               {"quads.glb", "glb"},
               {"quads.gltf", "gltf"},
               {"quads_external.gltf", "gltf"},
               {"quad.md2", "md2"},
               {"quad.dae", "dae"}};
  for (const auto& c : cases) {
    const Bytes bytes = read_file((fixtures / c.file).string());
    EXPECT_EQ(detect_mesh_format(bytes), c.format) << c.file;
    const std::string extension = fs::path(c.file).extension().string().substr(1);
    EXPECT_EQ(error_of([&] { check_content_matches_name(bytes, extension, c.file); }), "")
        << c.file;
  }
}

TEST(DetectFormat, ANameCannotChooseTheChecks) {
  const fs::path dir = test_dir();
  // An OFF face with index 7 of 3 vertices: refused as OFF, and refused under any other name.
  const std::string off = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n";
  for (const char* name : {"bad.off", "bad.glb", "bad.obj", "bad.ply", "bad.stl", "bad.3ds"}) {
    write_text(dir / name, off);
    const std::string message = error_of([&] { load_mesh((dir / name).string()); });
    EXPECT_NE(message.find(name), std::string::npos) << message;
    EXPECT_FALSE(message.empty()) << name << " was accepted";
    if (std::string(name) != "bad.off") {
      EXPECT_NE(message.find("the content is OFF (.off) but the name says"), std::string::npos)
          << message;
    }
  }
}

}  // namespace
}  // namespace splitray

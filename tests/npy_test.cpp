// The NumPy file reader and writer (io/npy.hpp): round trips, numpy's variants (float64,
// big-endian, Fortran order, .npz of one array), and clear errors for everything malformed.
#include "splitray/io/npy.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "splitray/core/errors.hpp"
#include "test_data.hpp"

namespace splitray {
namespace {

namespace fs = std::filesystem;

void write(const fs::path& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

// A .npy of `descr` / `shape` / raw data as numpy writes it (version 1.0, padded header).
std::string npy(const std::string& descr, const std::string& shape, const std::string& data,
                bool fortran = false) {
  std::string header = "{'descr': '" + descr +
                       "', 'fortran_order': " + (fortran ? "True" : "False") +
                       ", 'shape': " + shape + ", }";
  header.append((64 - (10 + header.size() + 1) % 64) % 64, ' ');
  header += '\n';
  std::string out = "\x93NUMPY\x01";
  out += '\0';
  out += static_cast<char>(header.size() & 0xff);
  out += static_cast<char>(header.size() >> 8);
  return out + header + data;
}

TEST(Npy, RoundTripsAndReadsNumpysVariants) {
  const fs::path dir = test::temp_dir("npy_variants");
  const std::vector<float> values{1, 2, 3, 4, 5, 6};
  write(dir / "a.npy", npy_bytes(npy_array({2, 3}, values)));
  const FloatArray a = read_npy_rows((dir / "a.npy").string(), 3, "points");
  EXPECT_EQ(a.shape, (std::vector<std::size_t>{2, 3}));
  EXPECT_EQ(a.values, values);
  // float64 in Fortran order: column-major data, the same array.
  std::string column_major;
  for (double d : {1.0, 4.0, 2.0, 5.0, 3.0, 6.0})
    column_major.append(reinterpret_cast<const char*>(&d), 8);
  write(dir / "f.npy", npy("<f8", "(2, 3)", column_major, true));
  EXPECT_EQ(read_npy_floats((dir / "f.npy").string()).values, values);
  // Big-endian float32.
  std::string big;
  for (float f : values) {
    const auto* b = reinterpret_cast<const char*>(&f);
    big += std::string{b[3], b[2], b[1], b[0]};
  }
  write(dir / "b.npy", npy(">f4", "(6,)", big));
  EXPECT_EQ(read_npy_floats((dir / "b.npy").string()).values, values);
  // A .npz of one array is read like the array.
  write_npz((dir / "one.npz").string(), {{"rays", npy_array({2, 3}, values)}});
  EXPECT_EQ(read_npy_floats((dir / "one.npz").string()).values, values);
  const auto members = read_npz((dir / "one.npz").string());
  ASSERT_EQ(members.size(), 1u);
  EXPECT_EQ(members[0].first, "rays");
}

TEST(Npy, MalformedFilesAreClearErrors) {
  const fs::path dir = test::temp_dir("npy_errors");
  const std::string six(24, '\0');
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"not numpy at all", "magic"},
      {npy("<f4", "(2, 3)", std::string(8, '\0')), "truncated"},
      {npy("<i4", "(2, 3)", six), "float32 or float64"},
      {npy("<f4", "(2, x)", six), "not a tuple of integers"},
      {npy("<f4", "(99999999999999, 99999999999)", six), "absurdly large"},
      {std::string("\x93NUMPY\x07\x00\x10\x00", 10), "version 7"},
      {std::string("\x93NUMPY\x01\x00\xff\x00{'descr'", 18), "header is truncated"},
  };
  int i = 0;
  for (const auto& [bytes, message] : cases) {
    const fs::path path = dir / ("bad" + std::to_string(i++) + ".npy");
    write(path, bytes);
    try {
      read_npy_floats(path.string());
      ADD_FAILURE() << "accepted: " << message;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
    }
  }
  write(dir / "rows.npy", npy_bytes(npy_array({2, 3}, std::vector<float>(6, 0.0f))));
  EXPECT_THROW(read_npy_rows((dir / "rows.npy").string(), 6, "rays"), Error);  // N x 3, not 6
  write(dir / "nan.npy", npy_bytes(npy_array({1, 3}, std::vector<float>{0, NAN, 0})));
  EXPECT_THROW(read_npy_rows((dir / "nan.npy").string(), 3, "points"), Error);
}

}  // namespace
}  // namespace splitray

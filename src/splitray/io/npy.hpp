#pragma once
// NumPy's file formats: .npy (one array, format versions 1.0-3.0) and .npz (a zip of .npy
// members, written uncompressed, as numpy.savez does), for users' own rays, points and
// queries and for the answers written back. Reading accepts little- and big-endian float32
// and float64 in C or Fortran order and returns float32 in C order; every malformed header,
// unsupported type or truncated file is an Error naming the file.
#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace splitray {

// An array ready to write: numpy's type string ("<f4", "<u4", "<i8"), shape, C-order bytes.
struct NpyArray {
  std::string descr;
  std::vector<std::size_t> shape;
  std::string bytes;
};

NpyArray npy_array(std::vector<std::size_t> shape, const std::vector<float>& values);
NpyArray npy_array(std::vector<std::size_t> shape, const std::vector<std::uint32_t>& values);
NpyArray npy_array(std::vector<std::size_t> shape, const std::vector<std::int64_t>& values);

// The bytes of a .npy file holding `array`.
std::string npy_bytes(const NpyArray& array);

// Writes a .npz of the named arrays (member NAME.npy each) atomically.
void write_npz(const std::string& path,
               const std::vector<std::pair<std::string, NpyArray>>& arrays);

// The arrays of a .npy file's bytes (`where` names it in errors): descr, shape, C-order bytes
// (Fortran-ordered 2-D arrays are transposed).
NpyArray parse_npy(const std::vector<unsigned char>& bytes, const std::string& where);
// The members of a .npz (stored or deflated), by name without ".npy".
std::vector<std::pair<std::string, NpyArray>> read_npz(const std::string& path);

struct FloatArray {
  std::vector<std::size_t> shape;
  std::vector<float> values;  // C order
};
// Reads a .npy file of floats (a .npz of one array too).
FloatArray read_npy_floats(const std::string& path);
// The same, requiring a 2-D shape of N x `columns` (N >= 1); `what` names the content in errors.
FloatArray read_npy_rows(const std::string& path, std::size_t columns, const std::string& what);

}  // namespace splitray

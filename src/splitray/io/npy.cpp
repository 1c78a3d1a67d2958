#include "splitray/io/npy.hpp"

#include <zlib.h>

#include <bit>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>

#include "splitray/core/errors.hpp"
#include "splitray/core/image.hpp"
#include "splitray/io/read_file.hpp"

namespace splitray {

namespace {

constexpr char kMagic[] = "\x93NUMPY";
constexpr std::size_t kMaxElements = std::size_t{1} << 32;

template <typename T>
NpyArray make(const char* descr, std::vector<std::size_t> shape, const std::vector<T>& values) {
  std::size_t count = 1;
  for (std::size_t d : shape) count *= d;
  if (count != values.size()) throw Error("npy", "shape and value count differ");
  NpyArray a{descr, std::move(shape), std::string(values.size() * sizeof(T), '\0')};
  static_assert(std::endian::native == std::endian::little, "npy output is little-endian");
  if (!values.empty()) std::memcpy(a.bytes.data(), values.data(), a.bytes.size());
  return a;
}

void put16(std::string& out, std::uint32_t v) {
  out += static_cast<char>(v & 0xff);
  out += static_cast<char>((v >> 8) & 0xff);
}
void put32(std::string& out, std::uint32_t v) {
  put16(out, v & 0xffff);
  put16(out, v >> 16);
}

// The header's Python literal: the value after 'key': up to the next top-level comma.
std::string header_value(const std::string& header, const std::string& key,
                         const std::string& path) {
  std::size_t at = header.find("'" + key + "'");
  if (at == std::string::npos) at = header.find("\"" + key + "\"");
  if (at == std::string::npos) throw Error(path, "the .npy header has no '" + key + "'");
  at = header.find(':', at);
  if (at == std::string::npos) throw Error(path, "the .npy header is malformed");
  ++at;
  while (at < header.size() && header[at] == ' ') ++at;
  std::size_t end = at;
  int depth = 0;
  while (end < header.size()) {
    const char c = header[end];
    if (c == '(' || c == '[') ++depth;
    if (c == ')' || c == ']') --depth;
    if ((c == ',' || c == '}') && depth == 0) break;
    ++end;
  }
  return header.substr(at, end - at);
}

std::vector<std::size_t> parse_shape(const std::string& text, const std::string& path) {
  if (text.size() < 2 || text.front() != '(' || text.back() != ')')
    throw Error(path, "the .npy shape '" + text + "' is not a tuple");
  std::vector<std::size_t> shape;
  std::size_t i = 1;
  while (i < text.size() - 1) {
    while (i < text.size() - 1 && (text[i] == ' ' || text[i] == ',')) ++i;
    if (i >= text.size() - 1) break;
    std::size_t value = 0, digits = 0;
    while (i < text.size() - 1 && text[i] >= '0' && text[i] <= '9') {
      if (value > kMaxElements) throw Error(path, "the .npy shape is absurdly large");
      value = value * 10 + static_cast<std::size_t>(text[i] - '0');
      ++i, ++digits;
    }
    if (digits == 0) throw Error(path, "the .npy shape '" + text + "' is not a tuple of integers");
    shape.push_back(value);
  }
  return shape;
}

}  // namespace

NpyArray npy_array(std::vector<std::size_t> shape, const std::vector<float>& values) {
  return make("<f4", std::move(shape), values);
}
NpyArray npy_array(std::vector<std::size_t> shape, const std::vector<std::uint32_t>& values) {
  return make("<u4", std::move(shape), values);
}
NpyArray npy_array(std::vector<std::size_t> shape, const std::vector<std::int64_t>& values) {
  return make("<i8", std::move(shape), values);
}

std::string npy_bytes(const NpyArray& array) {
  std::string shape;  // Python's tuple: (3,) and (3, 6)
  for (std::size_t i = 0; i < array.shape.size(); ++i)
    shape += (i > 0 ? ", " : "") + std::to_string(array.shape[i]);
  if (array.shape.size() == 1) shape += ",";
  std::string header =
      "{'descr': '" + array.descr + "', 'fortran_order': False, 'shape': (" + shape + "), }";
  // Version 1.0: magic, version, 2-byte length; the whole header padded to 64 bytes.
  const std::size_t total = 10 + header.size() + 1;
  header.append((64 - total % 64) % 64, ' ');
  header += '\n';
  std::string out(kMagic, 6);
  out += '\x01';
  out += '\x00';
  put16(out, static_cast<std::uint32_t>(header.size()));
  out += header;
  out += array.bytes;
  return out;
}

void write_npz(const std::string& path,
               const std::vector<std::pair<std::string, NpyArray>>& arrays) {
  std::string zip, directory;
  for (const auto& [name, array] : arrays) {
    const std::string member = name + ".npy";
    const std::string data = npy_bytes(array);
    if (data.size() >= 0xffffffffu || zip.size() >= 0xffffffffu)
      throw Error(path, "the arrays are too large for a .npz without zip64 (4 GiB)");
    const auto crc = static_cast<std::uint32_t>(
        crc32(0, reinterpret_cast<const Bytef*>(data.data()), static_cast<uInt>(data.size())));
    const auto offset = static_cast<std::uint32_t>(zip.size());
    const auto size = static_cast<std::uint32_t>(data.size());
    // Local file header: stored (no compression), no data descriptor.
    put32(zip, 0x04034b50);
    put16(zip, 20);    // version needed
    put16(zip, 0);     // flags
    put16(zip, 0);     // stored
    put16(zip, 0);     // time
    put16(zip, 0x21);  // date: 1980-01-01
    put32(zip, crc);
    put32(zip, size);
    put32(zip, size);
    put16(zip, static_cast<std::uint32_t>(member.size()));
    put16(zip, 0);
    zip += member;
    zip += data;
    // Its central directory entry.
    put32(directory, 0x02014b50);
    put16(directory, 20);  // made by
    put16(directory, 20);  // needed
    put16(directory, 0);
    put16(directory, 0);
    put16(directory, 0);
    put16(directory, 0x21);
    put32(directory, crc);
    put32(directory, size);
    put32(directory, size);
    put16(directory, static_cast<std::uint32_t>(member.size()));
    put16(directory, 0);  // extra
    put16(directory, 0);  // comment
    put16(directory, 0);  // disk
    put16(directory, 0);  // internal attributes
    put32(directory, 0);  // external attributes
    put32(directory, offset);
    directory += member;
  }
  const auto directory_offset = static_cast<std::uint32_t>(zip.size());
  zip += directory;
  put32(zip, 0x06054b50);
  put16(zip, 0);
  put16(zip, 0);
  put16(zip, static_cast<std::uint32_t>(arrays.size()));
  put16(zip, static_cast<std::uint32_t>(arrays.size()));
  put32(zip, static_cast<std::uint32_t>(directory.size()));
  put32(zip, directory_offset);
  put16(zip, 0);
  write_file_atomically(path, zip);
}

NpyArray parse_npy(const std::vector<unsigned char>& bytes, const std::string& path) {
  if (bytes.size() < 10 || std::memcmp(bytes.data(), kMagic, 6) != 0)
    throw Error(path, "not a .npy file (no \\x93NUMPY magic)");
  const int major = bytes[6];
  std::size_t header_length = 0, start = 0;
  if (major == 1) {
    header_length = bytes[8] | (std::size_t{bytes[9]} << 8);
    start = 10;
  } else if (major == 2 || major == 3) {
    if (bytes.size() < 12) throw Error(path, "the .npy header is truncated");
    header_length = bytes[8] | (std::size_t{bytes[9]} << 8) | (std::size_t{bytes[10]} << 16) |
                    (std::size_t{bytes[11]} << 24);
    start = 12;
  } else {
    throw Error(path, "unknown .npy format version " + std::to_string(major));
  }
  if (start + header_length > bytes.size()) throw Error(path, "the .npy header is truncated");
  const std::string header(bytes.begin() + static_cast<std::ptrdiff_t>(start),
                           bytes.begin() + static_cast<std::ptrdiff_t>(start + header_length));
  NpyArray out;
  out.descr = header_value(header, "descr", path);
  if (out.descr.size() >= 2 && (out.descr.front() == '\'' || out.descr.front() == '"'))
    out.descr = out.descr.substr(1, out.descr.size() - 2);
  const std::string order = header_value(header, "fortran_order", path);
  if (order != "False" && order != "True")
    throw Error(path, "the .npy fortran_order '" + order + "' is neither True nor False");
  out.shape = parse_shape(header_value(header, "shape", path), path);
  const std::size_t item =
      out.descr.size() >= 3 ? static_cast<std::size_t>(std::atoi(out.descr.c_str() + 2)) : 0;
  if (out.descr.size() < 3 || std::string("<>|=").find(out.descr[0]) == std::string::npos ||
      std::string("fiub").find(out.descr[1]) == std::string::npos ||
      (item != 1 && item != 2 && item != 4 && item != 8))
    throw Error(path, "unsupported array type '" + out.descr + "' (numbers only)");
  std::size_t count = 1;
  for (std::size_t d : out.shape) {
    if (d != 0 && count > kMaxElements / d) throw Error(path, "the .npy shape is absurdly large");
    count *= d;
  }
  const std::size_t data_start = start + header_length;
  if (bytes.size() - data_start < count * item)
    throw Error(path, "the .npy data is truncated: " + std::to_string(count) + " values of " +
                          std::to_string(item) + " bytes declared, " +
                          std::to_string(bytes.size() - data_start) + " bytes present");
  out.bytes.assign(reinterpret_cast<const char*>(bytes.data() + data_start), count * item);
  if (order == "True") {
    if (out.shape.size() > 2)
      throw Error(path, "Fortran-ordered arrays of more than 2 dimensions are not read");
    if (out.shape.size() == 2) {  // column-major to row-major
      const std::size_t rows = out.shape[0], cols = out.shape[1];
      std::string c(out.bytes.size(), '\0');
      for (std::size_t i = 0; i < rows; ++i)
        for (std::size_t j = 0; j < cols; ++j)
          std::memcpy(&c[(i * cols + j) * item], &out.bytes[(j * rows + i) * item], item);
      out.bytes = std::move(c);
    }
  }
  return out;
}

std::vector<std::pair<std::string, NpyArray>> read_npz(const std::string& path) {
  const Bytes zip = read_file(path);
  std::vector<std::pair<std::string, NpyArray>> out;
  const auto u16 = [&](std::size_t at) {
    if (at + 2 > zip.size()) throw Error(path, "the .npz (zip) is truncated");
    return static_cast<std::uint32_t>(zip[at] | (zip[at + 1] << 8));
  };
  const auto u32 = [&](std::size_t at) { return u16(at) | (u16(at + 2) << 16); };
  std::size_t at = 0;
  while (at + 4 <= zip.size() && u32(at) == 0x04034b50) {  // local file headers in order
    const std::uint32_t flags = u16(at + 6), method = u16(at + 8);
    const std::uint32_t compressed = u32(at + 18), size = u32(at + 22);
    const std::size_t name_length = u16(at + 26), extra = u16(at + 28);
    if (flags & 8)
      throw Error(path, "zip data descriptors are not supported (rewrite with numpy.savez)");
    const std::size_t data = at + 30 + name_length + extra;
    if (data + compressed > zip.size()) throw Error(path, "the .npz (zip) is truncated");
    std::string name(reinterpret_cast<const char*>(&zip[at + 30]), name_length);
    Bytes member;
    if (method == 0) {
      member.assign(zip.begin() + static_cast<std::ptrdiff_t>(data),
                    zip.begin() + static_cast<std::ptrdiff_t>(data + compressed));
    } else if (method == 8) {  // raw deflate
      member.resize(size);
      z_stream z{};
      if (inflateInit2(&z, -15) != Z_OK) throw Error(path, "zlib failed");
      z.next_in = const_cast<Bytef*>(&zip[data]);
      z.avail_in = compressed;
      z.next_out = member.data();
      z.avail_out = size;
      const int status = inflate(&z, Z_FINISH);
      inflateEnd(&z);
      if (status != Z_STREAM_END || z.total_out != size)
        throw Error(path, "member " + name + " is corrupt (deflate)");
    } else {
      throw Error(path, "member " + name + " uses zip compression method " +
                            std::to_string(method) + " (stored and deflate are read)");
    }
    if (name.size() > 4 && name.ends_with(".npy")) name.resize(name.size() - 4);
    out.emplace_back(name, parse_npy(member, path + " (" + name + ")"));
    at = data + compressed;
  }
  if (out.empty()) throw Error(path, "not a .npz file (no zip members)");
  return out;
}

FloatArray read_npy_floats(const std::string& path) {
  const Bytes bytes = read_file(path);
  NpyArray a;
  if (bytes.size() >= 4 && bytes[0] == 'P' && bytes[1] == 'K') {
    auto members = read_npz(path);
    if (members.size() != 1)
      throw Error(path, "the .npz holds " + std::to_string(members.size()) +
                            " arrays: give one array (a .npy, or a .npz of one)");
    a = std::move(members.front().second);
  } else {
    a = parse_npy(bytes, path);
  }
  const std::string& d = a.descr;
  const bool big_endian = d[0] == '>';
  const std::size_t item = d == "<f4" || d == ">f4" || d == "|f4" || d == "=f4" ? 4
                           : d == "<f8" || d == ">f8" || d == "=f8"             ? 8
                                                                                : 0;
  if (item == 0) throw Error(path, "the array's type is '" + d + "': float32 or float64 expected");
  FloatArray out;
  out.shape = a.shape;
  const std::size_t count = a.bytes.size() / item;
  out.values.resize(count);
  const char* p = a.bytes.data();
  for (std::size_t i = 0; i < count; ++i, p += item) {
    if (item == 4) {
      std::uint32_t bits;
      std::memcpy(&bits, p, 4);
      if (big_endian) bits = __builtin_bswap32(bits);
      out.values[i] = std::bit_cast<float>(bits);
    } else {
      std::uint64_t bits;
      std::memcpy(&bits, p, 8);
      if (big_endian) bits = __builtin_bswap64(bits);
      out.values[i] = static_cast<float>(std::bit_cast<double>(bits));
    }
  }
  return out;
}

FloatArray read_npy_rows(const std::string& path, std::size_t columns, const std::string& what) {
  FloatArray a = read_npy_floats(path);
  if (a.shape.size() != 2 || a.shape[1] != columns || a.shape[0] == 0) {
    std::string shape;
    for (std::size_t d : a.shape) shape += (shape.empty() ? "" : " x ") + std::to_string(d);
    throw Error(path, what + ": expected an N x " + std::to_string(columns) +
                          " array (N >= 1), got shape (" + shape + ")");
  }
  for (std::size_t i = 0; i < a.values.size(); ++i)
    if (!std::isfinite(a.values[i]))
      throw Error(path,
                  what + ": row " + std::to_string(i / columns) + " has a NaN or infinite value");
  return a;
}

}  // namespace splitray

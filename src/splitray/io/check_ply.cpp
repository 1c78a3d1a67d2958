// PLY: the header must be complete (assimp loops forever on a header without end_header),
// the data must hold every element the header declares (binary: byte-exact walk; ASCII:
// token walk) and every face index must name an existing vertex.
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "splitray/core/errors.hpp"
#include "splitray/io/format_checks.hpp"
#include "splitray/io/text_scan.hpp"

namespace splitray {
namespace {

enum class Encoding { ascii, little, big };

struct Type {
  std::size_t size = 0;
  bool is_float = false;
  bool is_signed = false;
};

struct Property {
  std::string name;
  Type type;
  bool is_list = false;
  Type count_type;  // lists only
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
};

std::optional<Type> parse_type(std::string_view s) {
  if (s == "char" || s == "int8") return Type{1, false, true};
  if (s == "uchar" || s == "uint8") return Type{1, false, false};
  if (s == "short" || s == "int16") return Type{2, false, true};
  if (s == "ushort" || s == "uint16") return Type{2, false, false};
  if (s == "int" || s == "int32") return Type{4, false, true};
  if (s == "uint" || s == "uint32") return Type{4, false, false};
  if (s == "float" || s == "float32") return Type{4, true, true};
  if (s == "double" || s == "float64") return Type{8, true, true};
  return std::nullopt;
}

bool is_face_index_list(const Element& e, const Property& p) {
  return e.name == "face" && p.is_list && (p.name == "vertex_indices" || p.name == "vertex_index");
}

// Reads one binary value as a double (indices and counts are exact up to 2^53).
double read_binary(const unsigned char* p, const Type& t, Encoding enc) {
  unsigned char b[8];
  std::memcpy(b, p, t.size);
  const bool swap = (enc == Encoding::big) != (std::endian::native == std::endian::big);
  if (swap)
    for (std::size_t i = 0; i < t.size / 2; ++i) std::swap(b[i], b[t.size - 1 - i]);
  if (t.is_float) {
    if (t.size == 4) {
      float f;
      std::memcpy(&f, b, 4);
      return f;
    }
    double d;
    std::memcpy(&d, b, 8);
    return d;
  }
  switch (t.size) {
    case 1:
      return t.is_signed ? double(std::int8_t(b[0])) : double(b[0]);
    case 2: {
      std::uint16_t u;
      std::memcpy(&u, b, 2);
      return t.is_signed ? double(std::int16_t(u)) : double(u);
    }
    default: {
      std::uint32_t u;
      std::memcpy(&u, b, 4);
      return t.is_signed ? double(std::int32_t(u)) : double(u);
    }
  }
}

struct Header {
  Encoding encoding = Encoding::ascii;
  std::vector<Element> elements;
  std::size_t data_offset = 0;
};

Header parse_header(std::string_view text, const std::string& where) {
  if (text.substr(0, 3) != "ply" || (text.size() > 3 && text[3] != '\n' && text[3] != '\r'))
    throw Error(where, "not a PLY file (it does not start with 'ply')");
  constexpr std::size_t kMaxHeader = 1 << 20;
  Header h;
  bool has_format = false, ended = false;
  scan::Lines lines(text.substr(0, std::min(text.size(), kMaxHeader)));
  std::string_view line;
  std::size_t offset = 0;
  lines.next(line);
  offset += line.size() + 1;
  while (!ended && lines.next(line)) {
    offset += line.size() + 1;
    const std::string at = where + ": header line " + std::to_string(lines.number());
    const auto tok = scan::tokens(line);
    if (tok.empty() || tok[0] == "comment" || tok[0] == "obj_info") continue;
    if (tok[0] == "format") {
      if (tok.size() < 2) throw Error(at, "'format' without a format");
      if (tok[1] == "ascii")
        h.encoding = Encoding::ascii;
      else if (tok[1] == "binary_little_endian")
        h.encoding = Encoding::little;
      else if (tok[1] == "binary_big_endian")
        h.encoding = Encoding::big;
      else
        throw Error(at, "unknown PLY format '" + std::string(tok[1]) + "'");
      has_format = true;
    } else if (tok[0] == "element") {
      const auto count = tok.size() == 3 ? scan::to_int(tok[2]) : std::nullopt;
      if (!count || *count < 0 || *count > 0xffffffffLL)
        throw Error(at, "expected 'element NAME COUNT' with a count below 2^32");
      h.elements.push_back({std::string(tok[1]), static_cast<std::uint64_t>(*count), {}});
    } else if (tok[0] == "property") {
      if (h.elements.empty()) throw Error(at, "a property before any element");
      Property p;
      if (tok.size() == 5 && tok[1] == "list") {
        const auto count_type = parse_type(tok[2]);
        const auto type = parse_type(tok[3]);
        if (!count_type || !type || count_type->is_float)
          throw Error(at, "unknown or unusable list types '" + std::string(tok[2]) + " " +
                              std::string(tok[3]) + "'");
        p = {std::string(tok[4]), *type, true, *count_type};
      } else if (tok.size() == 3) {
        const auto type = parse_type(tok[1]);
        if (!type) throw Error(at, "unknown property type '" + std::string(tok[1]) + "'");
        p = {std::string(tok[2]), *type, false, {}};
      } else {
        throw Error(at, "malformed property line");
      }
      h.elements.back().properties.push_back(p);
    } else if (tok[0] == "end_header") {
      ended = true;
    } else {
      throw Error(at, "unknown header keyword '" + std::string(tok[0]) + "'");
    }
  }
  if (!ended) throw Error(where, "the PLY header has no end_header line (truncated file?)");
  if (!has_format) throw Error(where, "the PLY header has no format line");
  for (const Element& e : h.elements)
    if (e.count > 0 && e.properties.empty())
      throw Error(where, "PLY element '" + e.name + "' has no properties");
  h.data_offset = std::min(offset, text.size());
  return h;
}

// A number of the file for a message: whole numbers as integers, anything else (fractions,
// values beyond 64 bits, NaN) as written by %g; never a cast of an out-of-range double.
std::string number_text(double v) {
  if (v == std::floor(v) && std::fabs(v) < 9.0e15) return std::to_string(std::int64_t(v));
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

struct FaceCheck {
  std::uint64_t vertices = 0;
  std::size_t triangles = 0;
  const std::string& where;

  void corners(std::uint64_t face, double n) const {
    if (n < 3)
      throw Error(
          where, "PLY face " + std::to_string(face) + " has " + number_text(n) +
                     " vertices; a face needs at least 3 (do the header's counts match the data?)");
  }
  void index(std::uint64_t face, double i) const {
    if (!(i >= 0 && i < double(vertices)))
      throw Error(where, "PLY face " + std::to_string(face) + " refers to vertex " +
                             number_text(i) + " but there are only " + std::to_string(vertices) +
                             " vertices (index out of range)");
    if (i != std::floor(i))
      throw Error(where, "PLY face " + std::to_string(face) + " refers to vertex " +
                             number_text(i) + ": a vertex index must be a whole number");
  }
};

std::string truncated(const Element& e, std::uint64_t item) {
  return "truncated: the header declares " + std::to_string(e.count) + " '" + e.name +
         "' elements but the data ends inside element number " + std::to_string(item + 1);
}

void walk_binary(const Header& h, std::span<const unsigned char> data, FaceCheck& faces,
                 const std::string& where) {
  std::size_t pos = 0;
  for (const Element& e : h.elements) {
    bool fixed = true;
    std::size_t item_size = 0;
    for (const Property& p : e.properties) {
      fixed = fixed && !p.is_list;
      item_size += p.type.size;
    }
    if (fixed) {  // one size check for the whole element
      const std::uint64_t need = e.count * item_size;
      if (need > data.size() - pos)
        throw Error(where, truncated(e, (data.size() - pos) / item_size));
      pos += need;
      continue;
    }
    for (std::uint64_t item = 0; item < e.count; ++item) {
      for (const Property& p : e.properties) {
        if (!p.is_list) {
          if (p.type.size > data.size() - pos) throw Error(where, truncated(e, item));
          pos += p.type.size;
          continue;
        }
        if (p.count_type.size > data.size() - pos) throw Error(where, truncated(e, item));
        const double n = read_binary(data.data() + pos, p.count_type, h.encoding);
        pos += p.count_type.size;
        if (n < 0)
          throw Error(where, "PLY '" + e.name + "' " + std::to_string(item) +
                                 " has a negative list length");
        const std::uint64_t len = static_cast<std::uint64_t>(n);
        if (len * p.type.size > data.size() - pos) throw Error(where, truncated(e, item));
        if (is_face_index_list(e, p)) {
          faces.corners(item, n);
          for (std::uint64_t k = 0; k < len; ++k)
            faces.index(item, read_binary(data.data() + pos + k * p.type.size, p.type, h.encoding));
          faces.triangles += len - 2;
        }
        pos += len * p.type.size;
      }
    }
  }
}

void walk_ascii(const Header& h, std::string_view data, FaceCheck& faces,
                const std::string& where) {
  std::size_t pos = 0;
  auto next = [&](const Element& e, std::uint64_t item) {
    while (pos < data.size() && (scan::is_space(data[pos]) || data[pos] == '\n')) ++pos;
    if (pos >= data.size()) throw Error(where, truncated(e, item));
    const std::size_t start = pos;
    while (pos < data.size() && !scan::is_space(data[pos]) && data[pos] != '\n') ++pos;
    const std::string_view token = data.substr(start, pos - start);
    const auto value = scan::to_number(token);
    if (!value)
      throw Error(where, "PLY '" + e.name + "' " + std::to_string(item) + ": '" +
                             std::string(token) + "' is not a number");
    return *value;
  };
  for (const Element& e : h.elements) {
    for (std::uint64_t item = 0; item < e.count; ++item) {
      for (const Property& p : e.properties) {
        if (!p.is_list) {
          next(e, item);
          continue;
        }
        const double n = next(e, item);
        // Below 2^64 before the cast (a cast of a larger double is undefined).
        if (!(n >= 0 && n < 18446744073709551616.0) ||
            n != static_cast<double>(static_cast<std::uint64_t>(n)))
          throw Error(where, "PLY '" + e.name + "' " + std::to_string(item) +
                                 " has an invalid list length");
        const bool is_face = is_face_index_list(e, p);
        if (is_face) faces.corners(item, n);
        for (std::uint64_t k = 0; k < static_cast<std::uint64_t>(n); ++k) {
          const double value = next(e, item);
          if (is_face) faces.index(item, value);
        }
        if (is_face) faces.triangles += static_cast<std::size_t>(n) - 2;
      }
    }
  }
}

}  // namespace

std::size_t check_ply(std::span<const unsigned char> bytes, const std::string& where) {
  const std::string_view text = scan::as_text(bytes);
  const Header h = parse_header(text, where);
  FaceCheck faces{0, 0, where};
  for (const Element& e : h.elements)
    if (e.name == "vertex") faces.vertices = e.count;
  if (h.encoding == Encoding::ascii)
    walk_ascii(h, text.substr(h.data_offset), faces, where);
  else
    walk_binary(h, bytes.subspan(h.data_offset), faces, where);
  return faces.triangles;
}

}  // namespace splitray

#include "splitray/query/point_io.hpp"

#include <algorithm>
#include <bit>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "splitray/core/errors.hpp"
#include "splitray/io/read_file.hpp"

namespace splitray {
namespace {

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::ranges::transform(ext, ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

// The whole file through io's reader (regular files only, size limit, noted as an input).
std::string read_text_file(const std::string& path) {
  const Bytes bytes = read_file(path);
  return std::string(bytes.begin(), bytes.end());
}

// ---- PLY ----------------------------------------------------------------------------------

enum class PlyFormat { ascii, little, big };

struct PlyProperty {
  std::string name;
  int size = 0;     // bytes of a scalar, or of each list item
  char kind = 'f';  // 'i' signed, 'u' unsigned, 'f' float
  bool list = false;
  int count_size = 0;  // list: bytes of the count
  char count_kind = 'u';
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

struct PlyHeader {
  PlyFormat format = PlyFormat::ascii;
  std::vector<PlyElement> elements;
  std::size_t body = 0;  // byte offset of the data
};

bool scalar_type(const std::string& t, int& size, char& kind) {
  static const struct {
    const char* name;
    int size;
    char kind;
  } types[] = {{"char", 1, 'i'},  {"int8", 1, 'i'},    {"uchar", 1, 'u'},  {"uint8", 1, 'u'},
               {"short", 2, 'i'}, {"int16", 2, 'i'},   {"ushort", 2, 'u'}, {"uint16", 2, 'u'},
               {"int", 4, 'i'},   {"int32", 4, 'i'},   {"uint", 4, 'u'},   {"uint32", 4, 'u'},
               {"float", 4, 'f'}, {"float32", 4, 'f'}, {"double", 8, 'f'}, {"float64", 8, 'f'}};
  for (const auto& type : types)
    if (t == type.name) {
      size = type.size;
      kind = type.kind;
      return true;
    }
  return false;
}

PlyHeader parse_ply_header(const std::string& path, const std::string& data) {
  PlyHeader header;
  std::size_t pos = 0;
  int line_number = 0;
  const auto next_line = [&](std::string& line) {
    if (pos >= data.size()) return false;
    std::size_t end = data.find('\n', pos);
    if (end == std::string::npos) end = data.size();
    line = data.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = std::min(end + 1, data.size());
    ++line_number;
    return true;
  };
  const auto fail = [&](const std::string& problem) {
    return Error(path, "PLY header line " + std::to_string(line_number) + ": " + problem);
  };
  std::string line;
  if (!next_line(line) || line != "ply") throw Error(path, "not a PLY file (no 'ply' magic line)");
  bool has_format = false;
  for (;;) {
    if (!next_line(line)) throw fail("the header has no end_header");
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword.empty() || keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "end_header") break;
    if (keyword == "format") {
      std::string format;
      words >> format;
      if (format == "ascii")
        header.format = PlyFormat::ascii;
      else if (format == "binary_little_endian")
        header.format = PlyFormat::little;
      else if (format == "binary_big_endian")
        header.format = PlyFormat::big;
      else
        throw fail("unknown format '" + format + "'");
      has_format = true;
    } else if (keyword == "element") {
      PlyElement element;
      std::string count;
      words >> element.name >> count;
      const auto [end, ec] =
          std::from_chars(count.data(), count.data() + count.size(), element.count);
      if (element.name.empty() || ec != std::errc() || end != count.data() + count.size())
        throw fail("expected 'element NAME COUNT' with a non-negative count");
      header.elements.push_back(element);
    } else if (keyword == "property") {
      if (header.elements.empty()) throw fail("a property before any element");
      PlyProperty property;
      std::string type;
      words >> type;
      if (type == "list") {
        std::string count_type, item_type;
        words >> count_type >> item_type >> property.name;
        property.list = true;
        if (!scalar_type(count_type, property.count_size, property.count_kind) ||
            property.count_kind == 'f' || !scalar_type(item_type, property.size, property.kind))
          throw fail("bad list property types '" + count_type + " " + item_type + "'");
      } else {
        words >> property.name;
        if (!scalar_type(type, property.size, property.kind))
          throw fail("unknown property type '" + type + "'");
      }
      if (property.name.empty()) throw fail("a property without a name");
      header.elements.back().properties.push_back(property);
    } else {
      throw fail("unknown keyword '" + keyword + "'");
    }
  }
  if (!has_format) throw Error(path, "the PLY header has no format line");
  header.body = pos;
  return header;
}

template <typename T>
T load_as(const unsigned char* bytes) {
  T value;
  std::memcpy(&value, bytes, sizeof(T));
  return value;
}

double read_binary(const char* p, int size, char kind, bool big_endian) {
  unsigned char bytes[8] = {};
  const bool swap = big_endian != (std::endian::native == std::endian::big);
  for (int i = 0; i < size && i < 8; ++i)
    bytes[i] = static_cast<unsigned char>(p[swap ? size - 1 - i : i]);
  switch (kind) {
    case 'f':
      return size == 4 ? load_as<float>(bytes) : load_as<double>(bytes);
    case 'i':
      return size == 1 ? load_as<std::int8_t>(bytes)
                       : (size == 2 ? load_as<std::int16_t>(bytes) : load_as<std::int32_t>(bytes));
    default:
      return size == 1
                 ? load_as<std::uint8_t>(bytes)
                 : (size == 2 ? load_as<std::uint16_t>(bytes) : load_as<std::uint32_t>(bytes));
  }
}

bool ply_declares_faces(const PlyHeader& header) {
  return std::ranges::any_of(header.elements, [](const PlyElement& e) {
    return (e.name == "face" || e.name == "tristrips") && e.count > 0;
  });
}

}  // namespace

std::vector<Vec3> load_ply_points(const std::string& path) {
  const std::string data = read_text_file(path);
  const PlyHeader header = parse_ply_header(path, data);
  const auto vertex_it =
      std::ranges::find(header.elements, std::string("vertex"), &PlyElement::name);
  if (vertex_it == header.elements.end()) throw Error(path, "the PLY file has no vertex element");
  int xyz[3] = {-1, -1, -1};
  for (std::size_t i = 0; i < vertex_it->properties.size(); ++i)
    for (int a = 0; a < 3; ++a)
      if (vertex_it->properties[i].name == std::string(1, static_cast<char>('x' + a))) {
        if (vertex_it->properties[i].list)
          throw Error(path, "vertex coordinate is a list property");
        xyz[a] = static_cast<int>(i);
      }
  if (xyz[0] < 0 || xyz[1] < 0 || xyz[2] < 0)
    throw Error(path, "the PLY vertex element lacks an x, y or z property");

  std::vector<Vec3> points;
  const std::uint64_t remaining = data.size() - header.body;
  if (header.format == PlyFormat::ascii) {
    // Every value takes at least two characters: a count beyond that is a lie.
    const auto too_many = [&](std::uint64_t count) { return count > remaining / 2 + 1; };
    std::istringstream body(data.substr(header.body));
    std::string line;
    std::size_t line_number = 0;
    for (const PlyElement& element : header.elements) {
      if (too_many(element.count))
        throw Error(path, "element '" + element.name + "' declares " +
                              std::to_string(element.count) +
                              " entries, more than the file can hold");
      const bool is_vertex = &element == &*vertex_it;
      if (is_vertex) points.reserve(element.count);
      for (std::uint64_t i = 0; i < element.count; ++i) {
        do {
          if (!std::getline(body, line))
            throw Error(path, "the file ends inside element '" + element.name + "' (entry " +
                                  std::to_string(i) + " of " + std::to_string(element.count) + ")");
          ++line_number;
        } while (line.find_first_not_of(" \t\r") == std::string::npos);
        if (!is_vertex) continue;
        std::istringstream words(line);
        double values[3] = {0, 0, 0};
        const auto number = [&]() {
          std::string word;
          double value = 0;
          if (!(words >> word) ||
              std::from_chars(word.data(), word.data() + word.size(), value).ec != std::errc())
            throw Error(path, "vertex " + std::to_string(i) + " (body line " +
                                  std::to_string(line_number) + "): expected a number");
          return value;
        };
        for (std::size_t p = 0; p < element.properties.size(); ++p) {
          const double value = number();
          if (element.properties[p].list) {
            if (!(value >= 0) || value > 1e6)
              throw Error(path, "vertex " + std::to_string(i) + ": bad list size");
            for (int item = 0; item < static_cast<int>(value); ++item) number();
            continue;
          }
          for (int a = 0; a < 3; ++a)
            if (static_cast<int>(p) == xyz[a]) values[a] = value;
        }
        points.push_back({static_cast<float>(values[0]), static_cast<float>(values[1]),
                          static_cast<float>(values[2])});
      }
      if (is_vertex) break;
    }
  } else {
    const bool big = header.format == PlyFormat::big;
    std::size_t pos = header.body;
    for (const PlyElement& element : header.elements) {
      const bool is_vertex = &element == &*vertex_it;
      bool fixed = std::ranges::none_of(element.properties, &PlyProperty::list);
      std::size_t stride = 0;  // bytes of an entry; with lists, the least an entry can take
      for (const PlyProperty& p : element.properties) stride += p.list ? p.count_size : p.size;
      if (stride == 0 && element.count > 0)
        throw Error(path, "element '" + element.name + "' has no properties");
      if (stride > 0 && element.count > (data.size() - pos) / stride)
        throw Error(path, "element '" + element.name + "' declares " +
                              std::to_string(element.count) + " entries, more than the file " +
                              (fixed ? "holds" : "can hold"));
      if (is_vertex) points.reserve(element.count);  // at most the file's size / stride
      for (std::uint64_t i = 0; i < element.count; ++i) {
        double values[3] = {0, 0, 0};
        for (std::size_t p = 0; p < element.properties.size(); ++p) {
          const PlyProperty& property = element.properties[p];
          std::uint64_t items = 1;
          if (property.list) {
            if (pos + property.count_size > data.size())
              throw Error(path, "the file ends inside element '" + element.name + "'");
            items = static_cast<std::uint64_t>(
                read_binary(data.data() + pos, property.count_size, property.count_kind, big));
            pos += property.count_size;
          }
          if (items > (data.size() - pos) / property.size)
            throw Error(path, "the file ends inside element '" + element.name + "' (entry " +
                                  std::to_string(i) + ")");
          if (is_vertex)
            for (int a = 0; a < 3; ++a)
              if (static_cast<int>(p) == xyz[a])
                values[a] = read_binary(data.data() + pos, property.size, property.kind, big);
          pos += items * property.size;
        }
        if (is_vertex)
          points.push_back({static_cast<float>(values[0]), static_cast<float>(values[1]),
                            static_cast<float>(values[2])});
      }
      if (is_vertex) break;
    }
  }
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!is_finite(points[i]))
      throw Error(path, "vertex " + std::to_string(i) + " has a NaN or infinite coordinate");
  if (points.empty()) throw Error(path, "the file holds no points");
  return points;
}

std::vector<Vec3> load_xyz_points(const std::string& path) {
  const std::string data = read_text_file(path);
  std::vector<Vec3> points;
  std::size_t pos = 0, line_number = 0;
  while (pos < data.size()) {
    std::size_t end = data.find('\n', pos);
    if (end == std::string::npos) end = data.size();
    const char* p = data.data() + pos;
    const char* const line_end = data.data() + end;
    pos = end + 1;
    ++line_number;
    const auto skip_space = [&] {
      while (p < line_end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
    };
    skip_space();
    if (p == line_end || *p == '#') continue;
    float v[3];
    for (int a = 0; a < 3; ++a) {
      skip_space();
      if (*p == '+') ++p;  // from_chars does not take a leading plus
      const auto [next, ec] = std::from_chars(p, line_end, v[a]);
      if (ec != std::errc() || (next < line_end && *next != ' ' && *next != '\t' && *next != '\r'))
        throw Error(path, "line " + std::to_string(line_number) +
                              ": expected three numbers (x y z) separated by spaces");
      p = next;
    }
    const Vec3 point{v[0], v[1], v[2]};
    if (!is_finite(point))
      throw Error(path, "line " + std::to_string(line_number) + ": a NaN or infinite coordinate");
    points.push_back(point);
  }
  if (points.empty()) throw Error(path, "the file holds no points");
  return points;
}

bool is_point_file(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".xyz" || ext == ".txt" || ext == ".pts") return true;
  if (ext != ".ply") return false;
  const Bytes bytes = read_file_head(path, 1 << 20);  // headers are short; no body needed
  const std::string head(bytes.begin(), bytes.end());
  return !ply_declares_faces(parse_ply_header(path, head));
}

std::vector<Vec3> load_points(const std::string& path) {
  return lower_extension(path) == ".ply" ? load_ply_points(path) : load_xyz_points(path);
}

}  // namespace splitray

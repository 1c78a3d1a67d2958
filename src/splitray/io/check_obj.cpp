// OBJ: every face index must name an existing vertex (assimp rejects some bad indices but
// ignores bad normal and texture indices), faces need three or more corners, vertex lines
// three coordinates.
#include <string>

#include "splitray/core/errors.hpp"
#include "splitray/io/format_checks.hpp"
#include "splitray/io/text_scan.hpp"

namespace splitray {
namespace {

struct Counter {
  const char* what;         // "vertex", "texture coordinate", "normal"
  std::size_t defined = 0;  // so far
  std::int64_t max_index = 0;
  std::size_t max_line = 0;
};

std::string at(const std::string& where, std::size_t line) {
  return where + ": line " + std::to_string(line);
}

// One index of a face corner: positive (1-based, may name a later line) or negative (relative).
void check_index(std::string_view text, Counter& counter, const std::string& where,
                 std::size_t line, std::string_view corner) {
  const auto value = scan::to_int(text);
  if (!value)
    throw Error(at(where, line), "'" + std::string(corner) + "' is not a valid face corner");
  if (*value == 0)
    throw Error(at(where, line),
                "face refers to " + std::string(counter.what) + " 0, but OBJ indices start at 1");
  if (*value < 0) {
    // Negated in unsigned arithmetic: -INT64_MIN does not fit an int64_t.
    if (std::uint64_t{0} - static_cast<std::uint64_t>(*value) > counter.defined)
      throw Error(at(where, line), "face refers to " + std::string(counter.what) + " " +
                                       std::to_string(*value) + " (relative) but only " +
                                       std::to_string(counter.defined) + " are defined before it");
  } else if (*value > counter.max_index) {
    counter.max_index = *value;
    counter.max_line = line;
  }
}

}  // namespace

std::size_t check_obj(std::span<const unsigned char> bytes, const std::string& where) {
  const std::string_view text = scan::as_text(bytes);
  if (text.find('\0') != std::string_view::npos)
    throw Error(where, "contains a NUL byte: binary data, not an OBJ text file");
  Counter vertices{"vertex"}, texcoords{"texture coordinate"}, normals{"normal"};
  std::size_t triangles = 0;
  scan::Lines lines(text);
  std::string_view raw;
  std::string joined;
  while (lines.next(raw)) {
    const std::size_t line = lines.number();
    // A backslash at the end of a line continues it on the next one.
    std::string_view content = raw;
    while (true) {
      std::size_t end = content.size();
      while (end > 0 && scan::is_space(content[end - 1])) --end;
      if (end == 0 || content[end - 1] != '\\') break;
      joined.assign(content.substr(0, end - 1));
      joined += ' ';
      std::string_view more;
      if (!lines.next(more)) break;
      joined += more;
      content = joined;
    }
    const auto tok = scan::tokens(content);
    if (tok.empty() || tok[0].front() == '#') continue;
    if (tok[0] == "v") {
      if (tok.size() < 4)
        throw Error(at(where, line), "a vertex needs 3 coordinates but has " +
                                         std::to_string(tok.size() - 1) + " (truncated line?)");
      for (std::size_t k = 1; k < 4; ++k)
        if (!scan::to_number(tok[k]))
          throw Error(at(where, line),
                      "vertex coordinate '" + std::string(tok[k]) + "' is not a number");
      ++vertices.defined;
    } else if (tok[0] == "vt") {
      ++texcoords.defined;
    } else if (tok[0] == "vn") {
      ++normals.defined;
    } else if (tok[0] == "f") {
      const std::size_t corners = tok.size() - 1;
      if (corners < 3)
        throw Error(at(where, line), "a face needs at least 3 vertices but has " +
                                         std::to_string(corners) + " (truncated line?)");
      for (std::size_t k = 1; k < tok.size(); ++k) {
        // v, v/t, v//n or v/t/n
        const std::string_view corner = tok[k];
        const std::size_t s1 = corner.find('/');
        check_index(corner.substr(0, s1), vertices, where, line, corner);
        if (s1 == std::string_view::npos) continue;
        const std::size_t s2 = corner.find('/', s1 + 1);
        const std::string_view t =
            corner.substr(s1 + 1, s2 == std::string_view::npos ? s2 : s2 - s1 - 1);
        if (!t.empty()) check_index(t, texcoords, where, line, corner);
        if (s2 == std::string_view::npos) continue;
        const std::string_view n = corner.substr(s2 + 1);
        if (!n.empty()) check_index(n, normals, where, line, corner);
      }
      triangles += corners - 2;
    }
  }
  for (const Counter* c : {&vertices, &texcoords, &normals})
    if (c->max_index > 0 && static_cast<std::size_t>(c->max_index) > c->defined)
      throw Error(at(where, c->max_line), "face refers to " + std::string(c->what) + " " +
                                              std::to_string(c->max_index) +
                                              " but the file defines only " +
                                              std::to_string(c->defined) + " (index out of range)");
  return triangles;
}

}  // namespace splitray

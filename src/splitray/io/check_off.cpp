// OFF: assimp clamps out-of-range indices to the last vertex, drops faces of 0 or more than 9
// corners, reads missing coordinates as 0 and treats comment lines inside the data as vertices,
// all without an error. This check reads the file the way assimp does and rejects all of that.
#include <algorithm>
#include <string>

#include "splitray/core/errors.hpp"
#include "splitray/io/format_checks.hpp"
#include "splitray/io/text_scan.hpp"

namespace splitray {
namespace {

// Skips whitespace, line ends and '#' comment lines, as assimp's OFF reader does between
// header tokens.
void skip_to_token(std::string_view text, std::size_t& pos) {
  for (;;) {
    while (pos < text.size() && (scan::is_space(text[pos]) || text[pos] == '\n')) ++pos;
    if (pos >= text.size() || text[pos] != '#') return;
    while (pos < text.size() && text[pos] != '\n') ++pos;
  }
}

std::string_view read_token(std::string_view text, std::size_t& pos) {
  skip_to_token(text, pos);
  const std::size_t start = pos;
  while (pos < text.size() && !scan::is_space(text[pos]) && text[pos] != '\n') ++pos;
  return text.substr(start, pos - start);
}

}  // namespace

std::size_t check_off(std::span<const unsigned char> bytes, const std::string& where) {
  const std::string_view text = scan::as_text(bytes);
  if (text.find('\0') != std::string_view::npos)
    throw Error(where, "contains a NUL byte: binary data, not an OFF text file");
  std::size_t pos = 0;
  // Header keyword: [ST][C][N][4][n]OFF, or none at all.
  std::size_t header_end = pos;
  std::string_view keyword = read_token(text, header_end);
  bool homogeneous = false;
  if (keyword.size() >= 3 && keyword.substr(keyword.size() - 3) == "OFF") {
    std::string_view prefix = keyword.substr(0, keyword.size() - 3);
    if (prefix.substr(0, 2) == "ST") prefix.remove_prefix(2);
    if (!prefix.empty() && prefix.front() == 'C') prefix.remove_prefix(1);
    if (!prefix.empty() && prefix.front() == 'N') prefix.remove_prefix(1);
    if (!prefix.empty() && prefix.front() == '4') homogeneous = true, prefix.remove_prefix(1);
    if (prefix == "n") throw Error(where, "nOFF files (with a dimension field) are not supported");
    if (!prefix.empty()) throw Error(where, "unknown OFF header '" + std::string(keyword) + "'");
    pos = header_end;
    std::size_t peek = pos;
    if (read_token(text, peek) == "BINARY")
      throw Error(where, "binary OFF files are not supported");
  }
  std::uint64_t counts[3];
  const char* names[3] = {"vertex", "face", "edge"};
  for (int k = 0; k < 3; ++k) {
    const std::string_view token = read_token(text, pos);
    const auto value = scan::to_int(token);
    if (!value || *value < 0 || *value > 0xffffffffLL)
      throw Error(
          where, "the OFF header needs vertex, face and edge counts; the " + std::string(names[k]) +
                     " count is " +
                     (token.empty() ? std::string("missing") : "'" + std::string(token) + "'"));
    counts[k] = static_cast<std::uint64_t>(*value);
  }
  const std::uint64_t vertices = counts[0], faces = counts[1];
  if (vertices == 0) throw Error(where, "the OFF header declares no vertices");
  if (faces == 0) throw Error(where, "the OFF header declares no faces: the mesh has no triangles");
  skip_to_token(text, pos);

  // The data: one vertex or face per non-empty line.
  scan::Lines lines(text.substr(pos));
  const std::size_t first_line =
      static_cast<std::size_t>(std::count(text.begin(), text.begin() + pos, '\n'));
  auto at = [&] { return where + ": line " + std::to_string(first_line + lines.number()); };
  std::string_view line;
  auto next_line = [&](const char* what, std::uint64_t done, std::uint64_t total) {
    do {
      if (!lines.next(line))
        throw Error(where, "truncated: the header declares " + std::to_string(total) + " " + what +
                               " but the file ends after " + std::to_string(done));
    } while (line.empty() || line == "\r");
    if (line.size() >= 4000) throw Error(at(), "line too long for assimp's OFF reader");
  };
  const std::size_t coordinates = homogeneous ? 4 : 3;
  for (std::uint64_t v = 0; v < vertices; ++v) {
    next_line("vertices", v, vertices);
    const auto tok = scan::tokens(line);
    if (tok.size() < coordinates)
      throw Error(at(), "vertex " + std::to_string(v) + " needs " + std::to_string(coordinates) +
                            " coordinates but has " + std::to_string(tok.size()));
    for (std::size_t k = 0; k < coordinates; ++k)
      if (!scan::to_number(tok[k]))
        throw Error(at(), "vertex " + std::to_string(v) + ": '" + std::string(tok[k]) +
                              "' is not a number");
  }
  std::size_t triangles = 0;
  for (std::uint64_t f = 0; f < faces; ++f) {
    next_line("faces", f, faces);
    const auto tok = scan::tokens(line);
    const auto n = tok.empty() ? std::nullopt : scan::to_int(tok[0]);
    if (!n)
      throw Error(at(), "face " + std::to_string(f) + " does not start with its vertex count");
    if (*n < 3)
      throw Error(at(), "face " + std::to_string(f) + " has " + std::to_string(*n) +
                            " vertices; a face needs at least 3");
    if (*n > 9)
      throw Error(at(), "face " + std::to_string(f) + " has " + std::to_string(*n) +
                            " vertices; assimp's OFF reader takes at most 9");
    if (tok.size() < static_cast<std::size_t>(*n) + 1)
      throw Error(at(), "face " + std::to_string(f) + " lists fewer indices than its count " +
                            std::to_string(*n) + " (truncated line?)");
    for (std::int64_t k = 1; k <= *n; ++k) {
      const auto index = scan::to_int(tok[static_cast<std::size_t>(k)]);
      if (!index || *index < 0 || static_cast<std::uint64_t>(*index) >= vertices)
        throw Error(at(), "face " + std::to_string(f) + " refers to vertex '" +
                              std::string(tok[static_cast<std::size_t>(k)]) +
                              "' but there are only " + std::to_string(vertices) +
                              " vertices (index out of range)");
    }
    triangles += static_cast<std::size_t>(*n) - 2;
  }
  return triangles;
}

}  // namespace splitray

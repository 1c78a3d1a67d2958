// STL: assimp takes a file as binary only when its size is exactly 84 + 50 * (triangle count
// in the header); anything else must be ASCII ("solid ..."). A binary file cut short or with a
// wrong count is reported as such instead of assimp's "cannot determine the representation".
#include <cstring>
#include <string>

#include "splitray/core/errors.hpp"
#include "splitray/io/format_checks.hpp"
#include "splitray/io/text_scan.hpp"

namespace splitray {

std::size_t check_stl(std::span<const unsigned char> bytes, const std::string& where) {
  const std::size_t size = bytes.size();
  std::uint32_t count = 0;
  if (size >= 84) std::memcpy(&count, bytes.data() + 80, 4);  // little-endian on every target
  const std::uint64_t binary_size = 84 + 50 * std::uint64_t{count};
  if (size >= 84 && binary_size == size) return count;

  const std::string_view text = scan::as_text(bytes);
  std::size_t start = 0;
  while (start < text.size() && (scan::is_space(text[start]) || text[start] == '\n')) ++start;
  if (text.substr(start, 5) != "solid") {
    if (size < 84)
      throw Error(where, "too small for a binary STL file (" + std::to_string(size) +
                             " bytes, at least 84 needed) and not ASCII STL");
    throw Error(where, "truncated or corrupt binary STL: the header declares " +
                           std::to_string(count) + " triangles, which need " +
                           std::to_string(binary_size) + " bytes, but the file has " +
                           std::to_string(size));
  }
  // ASCII: count facets; the last line must close the solid, else the file was cut short.
  std::size_t facets = 0, vertices = 0;
  std::string_view last_keyword;
  scan::Lines lines(text);
  std::string_view line;
  while (lines.next(line)) {
    const auto tok = scan::tokens(line);
    if (tok.empty()) continue;
    if (tok[0] == "facet") ++facets;
    if (tok[0] == "vertex") {
      if (tok.size() < 4)
        throw Error(where + ": line " + std::to_string(lines.number()),
                    "a vertex needs 3 coordinates (truncated line?)");
      for (std::size_t k = 1; k < 4; ++k)
        if (!scan::to_number(tok[k]))
          throw Error(where + ": line " + std::to_string(lines.number()),
                      "vertex coordinate '" + std::string(tok[k]) + "' is not a number");
      ++vertices;
    }
    last_keyword = tok[0];
  }
  if (last_keyword != "endsolid")
    throw Error(where, "truncated ASCII STL: the file does not end with 'endsolid'");
  if (vertices != 3 * facets)
    throw Error(where, "ASCII STL with " + std::to_string(facets) + " facets but " +
                           std::to_string(vertices) + " vertices (each facet needs 3)");
  return facets;
}

}  // namespace splitray

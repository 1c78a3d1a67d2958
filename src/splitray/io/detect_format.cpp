// The mesh format a file's content shows, so that a name cannot choose the checks: a PLY file
// renamed .glb must meet the PLY rules (or be refused), never slip past them into an importer
// that assimp picks by the content.
#include <cstdint>
#include <cstring>
#include <string>

#include "splitray/core/errors.hpp"
#include "splitray/io/format_checks.hpp"
#include "splitray/io/text_scan.hpp"

namespace splitray {
namespace {

bool starts_with(std::string_view text, std::string_view prefix) {
  return text.substr(0, prefix.size()) == prefix;
}

// The first token after whitespace and '#' comment lines (OFF files may begin with comments).
std::string_view first_token(std::string_view text) {
  std::size_t pos = 0;
  for (;;) {
    while (pos < text.size() && (scan::is_space(text[pos]) || text[pos] == '\n')) ++pos;
    if (pos >= text.size() || text[pos] != '#') break;
    while (pos < text.size() && text[pos] != '\n') ++pos;
  }
  const std::size_t start = pos;
  while (pos < text.size() && !scan::is_space(text[pos]) && text[pos] != '\n') ++pos;
  return text.substr(start, pos - start);
}

// [ST][C][N][4]OFF, the keyword check_off accepts (nOFF included, which it then refuses).
bool is_off_keyword(std::string_view word) {
  if (word.size() < 3 || word.size() > 8 || word.substr(word.size() - 3) != "OFF") return false;
  return word.substr(0, word.size() - 3).find_first_not_of("STCN4n") == std::string_view::npos;
}

// The format family of an extension, in detect_mesh_format's names.
std::string family(const std::string& extension) {
  if (extension == "gltf" || extension == "glb") return "gltf";
  return extension;
}

}  // namespace

std::string detect_mesh_format(std::span<const unsigned char> bytes) {
  const std::string_view text = scan::as_text(bytes);
  if (bytes.size() >= 2 && bytes[0] == 0x1f && bytes[1] == 0x8b) return "gzip";
  if (starts_with(text, "glTF")) return "glb";
  if (starts_with(text, "ply\n") || starts_with(text, "ply\r\n")) return "ply";
  if (starts_with(text, "IDP2")) return "md2";
  // Binary STL: exactly 84 + 50 * (the triangle count at byte 80) bytes, whatever the header.
  if (bytes.size() >= 84) {
    std::uint32_t count = 0;
    std::memcpy(&count, bytes.data() + 80, 4);
    if (84 + 50 * std::uint64_t{count} == bytes.size()) return "stl";
  }
  const std::size_t bom = starts_with(text, "\xEF\xBB\xBF") ? 3 : 0;  // UTF-8 text may have one
  const std::size_t start = text.find_first_not_of(" \t\r\n\f\v", bom);
  if (start == std::string_view::npos) return "";
  const std::string_view rest = text.substr(start);
  if (rest.front() == '{') return "gltf";  // JSON: glTF is the only JSON mesh format
  if (starts_with(rest, "solid") && rest.size() > 5 && (scan::is_space(rest[5]) || rest[5] == '\n'))
    return "stl";
  if (starts_with(rest, "<?xml") || starts_with(rest, "<COLLADA")) return "dae";
  if (is_off_keyword(first_token(text))) return "off";
  return "";
}

std::string format_name(const std::string& format) {
  if (format == "gzip") return "gzip-compressed data";
  if (format == "glb") return "binary glTF (.glb)";
  if (format == "gltf") return "glTF (.gltf, JSON)";
  if (format == "ply") return "PLY (.ply)";
  if (format == "md2") return "MD2 (.md2)";
  if (format == "stl") return "STL (.stl)";
  if (format == "dae") return "COLLADA (.dae, XML)";
  if (format == "off") return "OFF (.off)";
  if (format == "obj") return "OBJ (.obj)";
  return "." + format;
}

void check_content_matches_name(std::span<const unsigned char> bytes, const std::string& extension,
                                const std::string& where) {
  const std::string content = detect_mesh_format(bytes);
  const std::string named = family(extension);
  if (!content.empty() && family(content) != named)
    throw Error(where, "the content is " + format_name(content) + " but the name says " +
                           format_name(extension) +
                           "; refusing to guess: give the file the extension of its format" +
                           (content == "gzip" ? " followed by .gz" : ""));
  // glTF must show its signature: its check counts nothing in other content, and assimp would
  // then pick an importer by the content, unchecked. (PLY, STL and MD2 checks refuse content
  // without their signature themselves.)
  if (content.empty() && named == "gltf")
    throw Error(where, "the name says " + format_name(extension) +
                           " but the content is neither a JSON object nor binary glTF (no "
                           "'glTF' signature)");
}

}  // namespace splitray

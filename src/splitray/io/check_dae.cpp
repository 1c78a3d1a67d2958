// COLLADA: assimp 5.2's reader loops without end (allocating until memory runs out) on a
// non-digit inside an index list (<p>, <vcount>, <v>, <h>), sizes arrays straight from
// count attributes, and recurses once per nested <node>. This check rejects those inputs; it
// does not count triangles (assimp's own checks catch bad indices in this format).
#include <string>

#include "splitray/core/errors.hpp"
#include "splitray/io/format_checks.hpp"
#include "splitray/io/text_scan.hpp"

namespace splitray {
namespace {

constexpr int kMaxXmlDepth = 500;

bool is_name_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
         c == '-' || c == ':' || c == '.';
}

bool is_index_list(std::string_view tag) { return tag == "p" || tag == "vcount" || tag == "v" || tag == "h"; }

// count="N", stride="N" and offset="N" size arrays and loops: each must fit the file.
void check_sizes(std::string_view tag_text, std::size_t file_size, const std::string& where) {
  for (std::string_view attribute : {"count", "stride", "offset"}) {
    std::size_t pos = 0;
    while ((pos = tag_text.find(attribute, pos)) != std::string_view::npos) {
      const bool starts_word = pos > 0 && scan::is_space(tag_text[pos - 1]);
      pos += attribute.size();
      if (!starts_word) continue;
      std::size_t i = pos;
      while (i < tag_text.size() && scan::is_space(tag_text[i])) ++i;
      if (i >= tag_text.size() || tag_text[i] != '=') continue;
      ++i;
      while (i < tag_text.size() && scan::is_space(tag_text[i])) ++i;
      if (i >= tag_text.size() || (tag_text[i] != '"' && tag_text[i] != '\'')) continue;
      const char quote = tag_text[i++];
      const std::size_t end = tag_text.find(quote, i);
      const std::string_view value = tag_text.substr(i, end == std::string_view::npos ? end : end - i);
      const auto n = scan::to_int(value);
      if (!n || *n < 0 || static_cast<std::uint64_t>(*n) > file_size)
        throw Error(where, "COLLADA attribute " + std::string(attribute) + "=\"" +
                               std::string(value.substr(0, 40)) +
                               "\" is not a count that fits in the file");
    }
  }
}

}  // namespace

void check_dae(std::span<const unsigned char> bytes, const std::string& where) {
  const std::string_view text = scan::as_text(bytes);
  int depth = 0;
  std::size_t pos = 0;
  while ((pos = text.find('<', pos)) != std::string_view::npos) {
    const std::string_view rest = text.substr(pos);
    if (rest.starts_with("<!--")) {
      const std::size_t end = text.find("-->", pos + 4);
      pos = end == std::string_view::npos ? text.size() : end + 3;
      continue;
    }
    if (rest.starts_with("<![CDATA[")) {
      const std::size_t end = text.find("]]>", pos + 9);
      pos = end == std::string_view::npos ? text.size() : end + 3;
      continue;
    }
    const std::size_t close = text.find('>', pos);
    if (close == std::string_view::npos) break;  // malformed XML: assimp's parser reports it
    const std::string_view tag_text = text.substr(pos, close - pos + 1);
    pos = close + 1;
    if (tag_text.starts_with("<?") || tag_text.starts_with("<!")) continue;
    if (tag_text.starts_with("</")) {
      --depth;
      continue;
    }
    std::size_t name_end = 1;
    while (name_end < tag_text.size() && is_name_char(tag_text[name_end])) ++name_end;
    const std::string_view tag = tag_text.substr(1, name_end - 1);
    check_sizes(tag_text, bytes.size(), where);
    if (tag_text.ends_with("/>")) continue;
    if (++depth > kMaxXmlDepth)
      throw Error(where, "the XML nests deeper than " + std::to_string(kMaxXmlDepth) + " elements");
    if (is_index_list(tag)) {
      const std::size_t end = text.find('<', pos);
      const std::string_view content = text.substr(pos, end == std::string_view::npos ? end : end - pos);
      for (char c : content)
        if (!((c >= '0' && c <= '9') || c == '-' || c == '+' || scan::is_space(c) || c == '\n'))
          throw Error(where, "COLLADA <" + std::string(tag) + "> index list contains '" +
                                 std::string(1, c >= 32 && c < 127 ? c : '?') + "', not a number");
    }
  }
}

}  // namespace splitray

// COLLADA: assimp 5.2's reader loops without end (allocating until memory runs out) on a
// non-digit inside an index list (<p>, <vcount>, <v>, <h>), sizes arrays straight from count
// attributes, reads accessors past the end of their arrays (garbage coordinates, or a crash
// when the array is empty) and recurses once per nested element. This check rejects those
// inputs with a light scan of the XML; it does not count triangles (assimp's own checks catch
// bad indices in this format).
#include <map>
#include <string>
#include <vector>

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

bool is_index_list(std::string_view tag) {
  return tag == "p" || tag == "vcount" || tag == "v" || tag == "h";
}

// The value of attribute `name` in a start tag, if present.
std::optional<std::string_view> attribute(std::string_view tag_text, std::string_view name) {
  std::size_t pos = 0;
  while ((pos = tag_text.find(name, pos)) != std::string_view::npos) {
    const bool starts_word =
        pos > 0 && (scan::is_space(tag_text[pos - 1]) || tag_text[pos - 1] == '\n');
    pos += name.size();
    if (!starts_word) continue;
    std::size_t i = pos;
    while (i < tag_text.size() && (scan::is_space(tag_text[i]) || tag_text[i] == '\n')) ++i;
    if (i >= tag_text.size() || tag_text[i] != '=') continue;
    ++i;
    while (i < tag_text.size() && (scan::is_space(tag_text[i]) || tag_text[i] == '\n')) ++i;
    if (i >= tag_text.size() || (tag_text[i] != '"' && tag_text[i] != '\'')) continue;
    const char quote = tag_text[i++];
    const std::size_t end = tag_text.find(quote, i);
    return tag_text.substr(i, end == std::string_view::npos ? end : end - i);
  }
  return std::nullopt;
}

struct Accessor {
  std::string source;
  std::uint64_t count = 0, stride = 1, offset = 0, params = 0;
};

class DaeCheck {
 public:
  DaeCheck(std::size_t file_size, const std::string& where)
      : file_size_(file_size), where_(where) {}

  // count, stride and offset size arrays and loops: each must be a number that fits the file.
  std::uint64_t size_attribute(std::string_view tag_text, std::string_view name,
                               std::uint64_t fallback) const {
    const auto value = attribute(tag_text, name);
    if (!value) return fallback;
    const auto n = scan::to_int(*value);
    if (!n || *n < 0 || static_cast<std::uint64_t>(*n) > file_size_)
      throw Error(where_, "COLLADA attribute " + std::string(name) + "=\"" +
                              std::string(value->substr(0, 40)) +
                              "\" is not a count that fits in the file");
    return static_cast<std::uint64_t>(*n);
  }

  void array(std::string_view tag, std::string_view tag_text, std::string_view content) {
    if (!attribute(tag_text, "count"))
      throw Error(where_, "COLLADA <" + std::string(tag) + "> without a count attribute");
    const std::uint64_t count = size_attribute(tag_text, "count", 0);
    if (scan::tokens(content).size() < count)
      throw Error(where_, "COLLADA <" + std::string(tag) + "> has fewer values than its count " +
                              std::to_string(count));
    if (const auto id = attribute(tag_text, "id")) arrays_[std::string(*id)] = count;
  }

  void open_accessor(std::string_view tag_text) {
    Accessor a;
    a.source = std::string(attribute(tag_text, "source").value_or(""));
    if (!a.source.empty() && a.source[0] == '#') a.source.erase(0, 1);
    if (!attribute(tag_text, "count"))
      throw Error(where_, "COLLADA <accessor> without a count attribute");
    a.count = size_attribute(tag_text, "count", 0);
    a.stride = size_attribute(tag_text, "stride", 1);
    a.offset = size_attribute(tag_text, "offset", 0);
    if (a.stride == 0) throw Error(where_, "COLLADA <accessor> with stride 0");
    accessors_.push_back(a);
  }
  void param() {
    if (!accessors_.empty()) ++accessors_.back().params;
  }

  // Every accessor reads inside its array: offset + (count - 1) * stride + params values.
  void finish() const {
    for (const Accessor& a : accessors_) {
      const auto it = arrays_.find(a.source);
      if (it == arrays_.end()) continue;  // a missing source: assimp reports it
      const std::uint64_t width = std::max(a.stride, a.params);
      const std::uint64_t need = a.count == 0 ? 0 : a.offset + (a.count - 1) * a.stride + width;
      if (need > it->second)
        throw Error(where_, "COLLADA accessor of '" + a.source + "' reads " + std::to_string(need) +
                                " values but the array has " + std::to_string(it->second));
    }
  }

 private:
  std::size_t file_size_;
  const std::string& where_;
  std::map<std::string, std::uint64_t> arrays_;
  std::vector<Accessor> accessors_;
};

}  // namespace

void check_dae(std::span<const unsigned char> bytes, const std::string& where) {
  const std::string_view text = scan::as_text(bytes);
  DaeCheck check(bytes.size(), where);
  int depth = 0;
  std::size_t pos = 0;
  while ((pos = text.find('<', pos)) != std::string_view::npos) {
    const std::string_view rest = text.substr(pos);
    if (rest.starts_with("<!--") || rest.starts_with("<![CDATA[")) {
      const std::string_view close = rest.starts_with("<!--") ? "-->" : "]]>";
      const std::size_t end = text.find(close, pos + 4);
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
    const bool empty_element = tag_text.ends_with("/>");
    if (!empty_element && ++depth > kMaxXmlDepth)
      throw Error(where, "the XML nests deeper than " + std::to_string(kMaxXmlDepth) + " elements");
    const std::size_t content_end = empty_element ? pos : text.find('<', pos);
    const std::string_view content =
        text.substr(pos, (content_end == std::string_view::npos ? text.size() : content_end) - pos);
    for (std::string_view name : {"count", "stride", "offset"})
      check.size_attribute(tag_text, name, 0);
    if (tag.ends_with("_array")) {
      check.array(tag, tag_text, content);
    } else if (tag == "accessor") {
      check.open_accessor(tag_text);
    } else if (tag == "param") {
      check.param();
    } else if (is_index_list(tag)) {
      for (char c : content)
        if (!((c >= '0' && c <= '9') || c == '-' || c == '+' || scan::is_space(c) || c == '\n'))
          throw Error(where, "COLLADA <" + std::string(tag) + "> index list contains '" +
                                 std::string(1, c >= 32 && c < 127 ? c : '?') + "', not a number");
    }
  }
  check.finish();
}

}  // namespace splitray

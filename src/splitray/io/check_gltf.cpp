// glTF 1.0 / 2.0 (.gltf, .glb): assimp drops a triangle whose index is out of range and cuts
// index lists that are not a multiple of 3, with only a log message. This check counts the
// triangles each primitive describes so that the loader can compare; malformed JSON and
// broken references are left to assimp, which reports them. It also rejects JSON and node
// hierarchies nested deeply enough to overflow the stack of assimp's recursive readers.
#include <cstring>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "splitray/core/errors.hpp"
#include "splitray/io/format_checks.hpp"

namespace splitray {
namespace {

using json = nlohmann::json;

constexpr int kMaxJsonDepth = 200;
constexpr int kMaxNodeDepth = 1000;

// Bracket depth outside strings.
void check_json_depth(std::span<const unsigned char> text, const std::string& where) {
  int depth = 0;
  bool in_string = false, escaped = false;
  for (unsigned char c : text) {
    if (in_string) {
      if (escaped)
        escaped = false;
      else if (c == '\\')
        escaped = true;
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxJsonDepth)
        throw Error(where,
                    "the glTF JSON nests deeper than " + std::to_string(kMaxJsonDepth) + " levels");
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
}

// The longest parent-child chain of nodes; cycles are left to assimp, which reports them.
void check_node_depth(const json& root, const std::string& where) {
  const auto nodes = root.find("nodes");
  if (nodes == root.end() || !(nodes->is_array() || nodes->is_object())) return;
  std::vector<const json*> list;
  std::map<std::string, std::size_t> id;  // glTF 1.0 names nodes by string
  for (auto it = nodes->begin(); it != nodes->end(); ++it) {
    if (nodes->is_object()) id[it.key()] = list.size();
    list.push_back(&*it);
  }
  auto children = [&](std::size_t n, std::vector<std::size_t>& out) {
    out.clear();
    if (!list[n]->is_object()) return;
    const auto c = list[n]->find("children");
    if (c == list[n]->end() || !c->is_array()) return;
    for (const json& ref : *c) {
      if (ref.is_number_unsigned() && ref.get<std::size_t>() < list.size())
        out.push_back(ref.get<std::size_t>());
      if (ref.is_string())
        if (const auto f = id.find(ref.get<std::string>()); f != id.end()) out.push_back(f->second);
    }
  };
  // height[n]: longest chain below n, by depth-first search without recursion.
  std::vector<int> height(list.size(), -1);
  std::vector<char> on_path(list.size(), 0);
  std::vector<std::size_t> kids;
  for (std::size_t start = 0; start < list.size(); ++start) {
    if (height[start] >= 0) continue;
    std::vector<std::pair<std::size_t, bool>> stack{{start, false}};
    while (!stack.empty()) {
      auto [n, done] = stack.back();
      stack.pop_back();
      if (done) {
        on_path[n] = 0;
        int h = 0;
        children(n, kids);
        for (std::size_t k : kids) h = std::max(h, height[k] + 1);
        height[n] = h;
        if (h > kMaxNodeDepth)
          throw Error(where, "the node hierarchy is deeper than " + std::to_string(kMaxNodeDepth) +
                                 " levels");
        continue;
      }
      if (height[n] >= 0 || on_path[n]) continue;  // done already, or a cycle
      on_path[n] = 1;
      stack.push_back({n, true});
      children(n, kids);
      for (std::size_t k : kids)
        if (height[k] < 0 && !on_path[k]) stack.push_back({k, false});
    }
  }
}

// collection[ref] for glTF 2.0 (arrays, integer references) and 1.0 (objects, string ids).
const json* lookup(const json& root, const char* collection, const json& ref) {
  const auto it = root.find(collection);
  if (it == root.end()) return nullptr;
  if (it->is_array() && ref.is_number_unsigned() && ref.get<std::size_t>() < it->size())
    return &(*it)[ref.get<std::size_t>()];
  if (it->is_object() && ref.is_string()) {
    const auto found = it->find(ref.get<std::string>());
    return found == it->end() ? nullptr : &*found;
  }
  return nullptr;
}

std::optional<std::uint64_t> accessor_count(const json& root, const json& ref) {
  const json* accessor = lookup(root, "accessors", ref);
  if (!accessor || !accessor->is_object()) return std::nullopt;
  const auto count = accessor->find("count");
  if (count == accessor->end() || !count->is_number_unsigned()) return std::nullopt;
  return count->get<std::uint64_t>();
}

std::optional<std::size_t> count_triangles(const json& root, const std::string& where) {
  const auto meshes = root.find("meshes");
  if (meshes == root.end() || !(meshes->is_array() || meshes->is_object())) return std::nullopt;
  std::size_t triangles = 0;
  for (const json& mesh : *meshes) {
    if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array())
      return std::nullopt;
    for (const json& prim : mesh["primitives"]) {
      if (!prim.is_object()) return std::nullopt;
      if (prim.contains("extensions")) return std::nullopt;  // e.g. Draco: counts unknown here
      const auto mode_it = prim.find("mode");
      const std::uint64_t mode =
          mode_it == prim.end()
              ? 4
              : (mode_it->is_number_unsigned() ? mode_it->get<std::uint64_t>() : 99);
      if (mode > 6) return std::nullopt;
      std::optional<std::uint64_t> count;
      if (const auto indices = prim.find("indices"); indices != prim.end()) {
        count = accessor_count(root, *indices);
      } else if (const auto attributes = prim.find("attributes");
                 attributes != prim.end() && attributes->is_object() &&
                 attributes->contains("POSITION")) {
        count = accessor_count(root, (*attributes)["POSITION"]);
      }
      if (!count) return std::nullopt;
      if (mode == 4) {
        if (*count % 3 != 0)
          throw Error(where, "a triangle primitive has " + std::to_string(*count) +
                                 " indices, not a multiple of 3");
        triangles += *count / 3;
      } else if (mode == 5 || mode == 6) {
        triangles += *count >= 3 ? *count - 2 : 0;
      }
    }
  }
  return triangles;
}

}  // namespace

std::optional<std::size_t> check_gltf(std::span<const unsigned char> bytes,
                                      const std::string& where) {
  std::span<const unsigned char> text = bytes;
  if (bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0) {  // GLB container
    if (bytes.size() < 20) throw Error(where, "truncated GLB file (no chunk header)");
    std::uint32_t length = 0;
    std::memcpy(&length, bytes.data() + 12, 4);
    if (length > bytes.size() - 20)
      throw Error(where, "truncated GLB file (the JSON chunk is cut short)");
    text = bytes.subspan(20, length);
  }
  check_json_depth(text, where);
  const json root = json::parse(text.begin(), text.end(), nullptr, false);
  if (root.is_discarded() || !root.is_object()) return std::nullopt;  // assimp says what is wrong
  check_node_depth(root, where);
  return count_triangles(root, where);
}

}  // namespace splitray

#include "splitray/io/scene_json.hpp"

#include <cmath>
#include <filesystem>
#include <initializer_list>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string_view>
#include <vector>

#include "splitray/core/errors.hpp"
#include "splitray/io/mesh_io.hpp"
#include "splitray/io/read_file.hpp"

namespace splitray {
namespace {

using json = nlohmann::json;

constexpr std::size_t kMaxSceneBytes = std::size_t{64} << 20;
constexpr int kMaxNesting = 64;

std::string key_path(const std::string& where, std::string_view key) {
  return where.empty() ? std::string(key) : where + "." + std::string(key);
}
std::string index_path(const std::string& where, std::size_t i) {
  return where + "[" + std::to_string(i) + "]";
}

std::string type_name(const json& j) {
  switch (j.type()) {
    case json::value_t::null:
      return "null";
    case json::value_t::boolean:
      return "true/false";
    case json::value_t::string:
      return "a string";
    case json::value_t::array:
      return "an array";
    case json::value_t::object:
      return "an object";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float:
      return "a number";
    default:
      return "an unsupported value";
  }
}

// Every error names the scene file and the key path ("instances[1].transform[0].rotate").
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  [[noreturn]] void fail(const std::string& where, const std::string& problem) const {
    throw Error(where.empty() ? file_ : file_ + ": " + where, problem);
  }
  [[noreturn]] void wrong_type(const json& j, const std::string& where,
                               const char* expected) const {
    fail(where, std::string("expected ") + expected + ", got " + type_name(j));
  }

  void object(const json& j, const std::string& where,
              std::initializer_list<std::string_view> allowed) const {
    if (!j.is_object()) wrong_type(j, where, "an object");
    for (const auto& item : j.items()) {
      bool known = false;
      for (std::string_view a : allowed) known = known || item.key() == a;
      if (known) continue;
      std::string list;
      for (std::string_view a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
      fail(where, "unknown key '" + item.key() + "' (allowed here: " + list + ")");
    }
  }
  const json& required(const json& j, const std::string& where, const char* key) const {
    const auto it = j.find(key);
    if (it == j.end()) fail(where, std::string("missing required key '") + key + "'");
    return *it;
  }
  const json* optional(const json& j, const char* key) const {
    const auto it = j.find(key);
    return it == j.end() ? nullptr : &*it;
  }
  const json& array(const json& j, const std::string& where) const {
    if (!j.is_array()) wrong_type(j, where, "an array");
    return j;
  }
  float number(const json& j, const std::string& where) const {
    if (!j.is_number()) wrong_type(j, where, "a number");
    const auto value = static_cast<float>(j.get<double>());
    if (!std::isfinite(value)) fail(where, "the number is too large for a float");
    return value;
  }
  float number_in(const json& j, const std::string& where, float lo, float hi,
                  const char* range) const {
    const float value = number(j, where);
    if (!(value >= lo && value <= hi)) fail(where, std::string("must be ") + range);
    return value;
  }
  Vec3 vec3(const json& j, const std::string& where) const {
    if (!j.is_array() || j.size() != 3) wrong_type(j, where, "an array of 3 numbers");
    return {number(j[0], index_path(where, 0)), number(j[1], index_path(where, 1)),
            number(j[2], index_path(where, 2))};
  }
  // A colour: [r, g, b] or one number for grey; no negative components.
  Vec3 color(const json& j, const std::string& where) const {
    const Vec3 c = j.is_number() ? Vec3(number(j, where)) : vec3(j, where);
    if (c.x < 0 || c.y < 0 || c.z < 0) fail(where, "colour components must not be negative");
    return c;
  }
  std::string string(const json& j, const std::string& where) const {
    if (!j.is_string()) wrong_type(j, where, "a string");
    const std::string s = j.get<std::string>();
    if (s.empty()) fail(where, "must not be empty");
    // A file name "ok.obj\u0000x" would open ok.obj: no NUL in any string of a scene.
    if (s.find('\0') != std::string::npos)
      fail(where, "'" + s + "' contains a NUL character (\\u0000)");
    return s;
  }
  bool boolean(const json& j, const std::string& where) const {
    if (!j.is_boolean()) wrong_type(j, where, "true or false");
    return j.get<bool>();
  }
  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

float determinant(const Transform& t) {
  const auto& m = t.m;
  return m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
         m[2] * (m[4] * m[9] - m[5] * m[8]);
}

Transform parse_step(const Reader& r, const json& j, const std::string& where) {
  r.object(j, where, {"translate", "rotate", "scale", "matrix"});
  if (j.size() != 1)
    r.fail(where, "a transform step has exactly one of translate, rotate, scale, matrix");
  const std::string key = j.begin().key();
  const json& value = j.begin().value();
  const std::string at = key_path(where, key);
  if (key == "translate") return Transform::translate(r.vec3(value, at));
  if (key == "rotate") {
    r.object(value, at, {"axis", "degrees"});
    const Vec3 axis = r.vec3(r.required(value, at, "axis"), key_path(at, "axis"));
    if (axis == Vec3{}) r.fail(key_path(at, "axis"), "the rotation axis must not be zero");
    return Transform::rotate(axis,
                             r.number(r.required(value, at, "degrees"), key_path(at, "degrees")));
  }
  if (key == "scale") {
    const Vec3 s = value.is_number() ? Vec3(r.number(value, at)) : r.vec3(value, at);
    if (s.x == 0 || s.y == 0 || s.z == 0) r.fail(at, "scale factors must not be zero");
    return Transform::scale(s);
  }
  // matrix: 12 (3x4) or 16 (4x4) numbers, row-major.
  if (!value.is_array() || (value.size() != 12 && value.size() != 16))
    r.wrong_type(value, at, "an array of 12 or 16 numbers (row-major)");
  Transform t;
  for (std::size_t i = 0; i < 12; ++i) t.m[i] = r.number(value[i], index_path(at, i));
  if (value.size() == 16) {
    const float last[4] = {0, 0, 0, 1};
    for (std::size_t i = 12; i < 16; ++i)
      if (r.number(value[i], index_path(at, i)) != last[i - 12])
        r.fail(at, "the last row of a 4x4 matrix must be 0 0 0 1 (no projective transforms)");
  }
  return t;
}

// One step or an array of steps; steps apply to the mesh in the order listed.
Transform parse_transform(const Reader& r, const json& j, const std::string& where) {
  Transform t;
  if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i) t = parse_step(r, j[i], index_path(where, i)) * t;
  } else if (j.is_object()) {
    t = parse_step(r, j, where);
  } else {
    r.wrong_type(j, where, "a transform step or an array of steps");
  }
  const float det = determinant(t);
  if (!std::isfinite(det) || det == 0)
    r.fail(where, "the transform is singular (it flattens the mesh)");
  for (float v : t.m)
    if (!std::isfinite(v)) r.fail(where, "the transform overflows");
  return t;
}

Material parse_material(const Reader& r, const json& j, const std::string& where) {
  r.object(j, where,
           {"name", "diffuse", "specular", "shininess", "reflectivity", "transparency", "ior",
            "fresnel"});
  Material m;
  m.name = r.string(r.required(j, where, "name"), key_path(where, "name"));
  if (const json* v = r.optional(j, "diffuse")) m.diffuse = r.color(*v, key_path(where, "diffuse"));
  if (const json* v = r.optional(j, "specular"))
    m.specular = r.color(*v, key_path(where, "specular"));
  if (const json* v = r.optional(j, "shininess"))
    m.shininess = r.number_in(*v, key_path(where, "shininess"), 0, 1e6f, "between 0 and 1e6");
  if (const json* v = r.optional(j, "reflectivity"))
    m.reflectivity = r.number_in(*v, key_path(where, "reflectivity"), 0, 1, "between 0 and 1");
  if (const json* v = r.optional(j, "transparency"))
    m.transparency = r.number_in(*v, key_path(where, "transparency"), 0, 1, "between 0 and 1");
  if (const json* v = r.optional(j, "ior"))
    m.ior = r.number_in(*v, key_path(where, "ior"), 1e-3f, 100, "between 0.001 and 100");
  if (const json* v = r.optional(j, "fresnel"))
    m.fresnel = r.boolean(*v, key_path(where, "fresnel"));
  return m;
}

Light parse_light(const Reader& r, const json& j, const std::string& where) {
  if (!j.is_object()) r.wrong_type(j, where, "an object");
  const std::string type = r.string(r.required(j, where, "type"), key_path(where, "type"));
  Light light;
  if (type == "point") {
    r.object(j, where, {"type", "position", "color", "intensity"});
    light.kind = Light::Kind::point;
    light.position = r.vec3(r.required(j, where, "position"), key_path(where, "position"));
    if (const json* v = r.optional(j, "intensity"))
      light.intensity = r.number_in(*v, key_path(where, "intensity"), 0, 3e38f, "0 or more");
  } else if (type == "directional") {
    r.object(j, where, {"type", "direction", "color"});
    light.kind = Light::Kind::directional;
    light.direction = r.vec3(r.required(j, where, "direction"), key_path(where, "direction"));
    if (light.direction == Vec3{})
      r.fail(key_path(where, "direction"), "the direction must not be zero");
    light.direction = normalize(light.direction);
  } else {
    r.fail(key_path(where, "type"), "unknown light type '" + type + "' (point or directional)");
  }
  if (const json* v = r.optional(j, "color")) light.color = r.color(*v, key_path(where, "color"));
  return light;
}

Camera parse_camera(const Reader& r, const json& j, const std::string& where) {
  r.object(j, where, {"eye", "target", "up", "fov"});
  Camera cam;
  cam.eye = r.vec3(r.required(j, where, "eye"), key_path(where, "eye"));
  cam.target = r.vec3(r.required(j, where, "target"), key_path(where, "target"));
  if (cam.eye == cam.target) r.fail(where, "eye and target must differ");
  if (const json* v = r.optional(j, "up")) {
    cam.up = r.vec3(*v, key_path(where, "up"));
    if (cam.up == Vec3{}) r.fail(key_path(where, "up"), "the up vector must not be zero");
  }
  if (const json* v = r.optional(j, "fov"))
    cam.vfov_degrees =
        r.number_in(*v, key_path(where, "fov"), 1e-3f, 179, "between 0.001 and 179 degrees");
  if (const std::string problem = cam.problem(); !problem.empty()) r.fail(where, problem);
  return cam;
}

// Parses with comments allowed; duplicate keys (which nlohmann would silently collapse) and
// absurd nesting are errors.
json parse_json(const Bytes& bytes, const std::string& path) {
  std::vector<std::set<std::string>> open_objects;
  auto callback = [&](int depth, json::parse_event_t event, json& parsed) {
    if (depth > kMaxNesting)
      throw Error(path, "the JSON nests deeper than " + std::to_string(kMaxNesting) + " levels");
    if (event == json::parse_event_t::object_start) open_objects.emplace_back();
    if (event == json::parse_event_t::object_end && !open_objects.empty()) open_objects.pop_back();
    if (event == json::parse_event_t::key && !open_objects.empty()) {
      const std::string key = parsed.get<std::string>();
      if (!open_objects.back().insert(key).second) throw Error(path, "duplicate key '" + key + "'");
    }
    return true;
  };
  try {
    return json::parse(bytes.begin(), bytes.end(), callback, true, true);
  } catch (const json::exception& e) {
    std::string message = e.what();
    if (const auto close = message.find("] ");
        message.starts_with("[json.exception") && close != std::string::npos)
      message = message.substr(close + 2);
    throw Error(path, "invalid JSON: " + message);
  }
}

}  // namespace

Scene load_json_scene(const std::string& path) {
  const json root = parse_json(read_maybe_gzipped(path, kMaxSceneBytes), path);
  const Reader r(path);
  r.object(root, "", {"instances", "materials", "lights", "camera", "background", "ambient"});

  Scene scene;
  if (const json* v = r.optional(root, "materials")) {
    std::set<std::string> names;
    for (std::size_t i = 0; i < r.array(*v, "materials").size(); ++i) {
      const std::string where = index_path("materials", i);
      Material m = parse_material(r, (*v)[i], where);
      if (!names.insert(m.name).second)
        r.fail(key_path(where, "name"), "duplicate material name '" + m.name + "'");
      if (m.name == scene.materials[0].name)
        scene.materials[0] = std::move(m);  // redefines "default"
      else
        scene.materials.push_back(std::move(m));
    }
  }

  const json& instances = r.array(r.required(root, "", "instances"), "instances");
  if (instances.empty()) r.fail("instances", "the scene needs at least one instance");
  const std::filesystem::path base = std::filesystem::path(path).parent_path();
  std::map<std::string, std::uint32_t> mesh_index;  // resolved path -> mesh
  for (std::size_t i = 0; i < instances.size(); ++i) {
    const std::string where = index_path("instances", i);
    const json& j = instances[i];
    r.object(j, where, {"mesh", "material", "transform"});
    Instance inst;
    const std::string file = r.string(r.required(j, where, "mesh"), key_path(where, "mesh"));
    const std::string resolved = (base / file).lexically_normal().string();
    if (const auto it = mesh_index.find(resolved); it != mesh_index.end()) {
      inst.mesh = it->second;
    } else {
      try {
        scene.meshes.push_back(
            load_mesh(resolved, {.materials = true, .warnings = &scene.warnings}));
      } catch (const Error& e) {
        r.fail(key_path(where, "mesh"), e.what());
      }
      inst.mesh = static_cast<std::uint32_t>(scene.meshes.size() - 1);
      mesh_index.emplace(resolved, inst.mesh);
    }
    if (const json* v = r.optional(j, "material")) {
      const std::string name = r.string(*v, key_path(where, "material"));
      bool found = false;
      for (std::size_t m = 0; m < scene.materials.size() && !found; ++m)
        if (scene.materials[m].name == name)
          inst.material = static_cast<std::uint32_t>(m), found = true;
      if (!found) r.fail(key_path(where, "material"), "unknown material '" + name + "'");
    }
    if (const json* v = r.optional(j, "transform"))
      inst.transform = parse_transform(r, *v, key_path(where, "transform"));
    scene.instances.push_back(inst);
  }

  if (const json* v = r.optional(root, "background")) scene.background = r.color(*v, "background");
  if (const json* v = r.optional(root, "ambient")) scene.ambient = r.color(*v, "ambient");
  if (const json* v = r.optional(root, "camera")) scene.camera = parse_camera(r, *v, "camera");
  const Aabb box = scene.bounds();
  if (!is_finite(box.lo) || !is_finite(box.hi))
    r.fail("instances", "the transforms move vertices to infinite coordinates");
  if (!scene.camera) scene.camera = Camera::frame(box);
  if (const json* v = r.optional(root, "lights")) {
    for (std::size_t i = 0; i < r.array(*v, "lights").size(); ++i)
      scene.lights.push_back(parse_light(r, (*v)[i], index_path("lights", i)));
  } else {
    scene.lights_fit_view = true;  // lit for the camera's view once it is known
  }
  scene.validate(path);
  return scene;
}

}  // namespace splitray

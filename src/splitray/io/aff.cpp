// The BART AFF reader (aff.hpp). Parsing builds a tree of transform nodes (static `xs`
// matrices and key-framed `x` transforms) and lists of triangles in their nodes' local
// space; triangles_at(t) evaluates every node's matrix at t, parents first.
#include "splitray/io/aff.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <numbers>

#include "splitray/core/coordinates.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/io/read_file.hpp"

namespace splitray {

namespace {

constexpr std::size_t kMaxCount = std::size_t{1} << 26;  // of any list in one statement
constexpr std::size_t kMaxTriangles = std::size_t{1} << 28;
// Limits against hostile scenes: includes nested without end (a cycle), a file that includes
// itself twice per level (2^depth files), and `x { ... }` blocks nested deep enough to
// overflow the parser's stack. BART's largest scene (robots) reads about 500 files, 3 MB.
constexpr int kMaxIncludeDepth = 32;
constexpr std::size_t kMaxIncludedFiles = 10'000;                  // in all, repeats counted
constexpr std::size_t kMaxIncludedBytes = std::size_t{256} << 20;  // 256 MiB in all
constexpr int kMaxBlockDepth = 256;
constexpr int kConeSegments = 16;
constexpr int kSphereRings = 12, kSphereSegments = 24;

// Affine 3x4 matrix, rows.
struct Affine {
  double m[3][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}};
  Vec3 apply(const Vec3& p) const {
    Vec3 r;
    for (int i = 0; i < 3; ++i)
      r[i] = static_cast<float>(m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3]);
    return r;
  }
  friend Affine operator*(const Affine& a, const Affine& b) {
    Affine r;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 4; ++j) {
        double s = j == 3 ? a.m[i][3] : 0;
        for (int k = 0; k < 3; ++k) s += a.m[i][k] * b.m[k][j];
        r.m[i][j] = s;
      }
    return r;
  }
};

using Quat = std::array<double, 4>;  // w, x, y, z

Quat axis_angle(double x, double y, double z, double degrees) {
  const double len = std::sqrt(x * x + y * y + z * z);
  if (!(len > 0)) return {1, 0, 0, 0};
  const double half = degrees * std::numbers::pi / 360.0, s = std::sin(half) / len;
  return {std::cos(half), x * s, y * s, z * s};
}

// T * R * S: scale, then rotate, then translate (BART's order).
Affine trs(const std::array<double, 3>& t, const Quat& q, const std::array<double, 3>& s) {
  const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  const double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
  const double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                          {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                          {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
  Affine a;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) a.m[i][j] = r[i][j] * s[j];
    a.m[i][3] = t[i];
  }
  return a;
}

// One Kochanek-Bartels spline over vectors of D components.
template <int D>
struct KbSpline {
  struct Key {
    double time;
    std::array<double, D> value;
    double tension, continuity, bias;
  };
  std::vector<Key> keys;

  std::array<double, D> at(double t) const {
    const std::size_t n = keys.size();
    if (n == 1 || t <= keys.front().time) return keys.front().value;
    if (t >= keys.back().time) return keys.back().value;
    std::size_t i = 0;
    while (i + 2 < n && t >= keys[i + 1].time) ++i;
    const Key &k0 = keys[i], &k1 = keys[i + 1];
    const double dt = k1.time - k0.time;
    const double u = dt > 0 ? (t - k0.time) / dt : 0;
    const auto out_tangent = [&](std::size_t k) {  // leaving key k
      const Key& c = keys[k];
      const Key& p = keys[k > 0 ? k - 1 : k];
      const Key& nx = keys[k + 1 < n ? k + 1 : k];
      const double a = (1 - c.tension) * (1 + c.continuity) * (1 + c.bias) / 2;
      const double b = (1 - c.tension) * (1 - c.continuity) * (1 - c.bias) / 2;
      const double span = nx.time - p.time;
      const double scale = span > 0 ? 2 * (nx.time - c.time) / span : 1;
      std::array<double, D> r;
      for (int d = 0; d < D; ++d)
        r[d] = scale * (a * (c.value[d] - p.value[d]) + b * (nx.value[d] - c.value[d]));
      return r;
    };
    const auto in_tangent = [&](std::size_t k) {  // arriving at key k
      const Key& c = keys[k];
      const Key& p = keys[k > 0 ? k - 1 : k];
      const Key& nx = keys[k + 1 < n ? k + 1 : k];
      const double a = (1 - c.tension) * (1 - c.continuity) * (1 + c.bias) / 2;
      const double b = (1 - c.tension) * (1 + c.continuity) * (1 - c.bias) / 2;
      const double span = nx.time - p.time;
      const double scale = span > 0 ? 2 * (c.time - p.time) / span : 1;
      std::array<double, D> r;
      for (int d = 0; d < D; ++d)
        r[d] = scale * (a * (c.value[d] - p.value[d]) + b * (nx.value[d] - c.value[d]));
      return r;
    };
    const auto m0 = out_tangent(i), m1 = in_tangent(i + 1);
    const double u2 = u * u, u3 = u2 * u;
    const double h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u, h01 = -2 * u3 + 3 * u2,
                 h11 = u3 - u2;
    std::array<double, D> r;
    for (int d = 0; d < D; ++d)
      r[d] = h00 * k0.value[d] + h10 * m0[d] + h01 * k1.value[d] + h11 * m1[d];
    return r;
  }
};

struct Keyframes {
  KbSpline<3> translation, scale;
  KbSpline<4> rotation;  // quaternions, signs made consistent, renormalised after evaluation

  Affine at(double t) const {
    std::array<double, 3> tr{0, 0, 0}, sc{1, 1, 1};
    Quat q{1, 0, 0, 0};
    if (!translation.keys.empty()) tr = translation.at(t);
    if (!scale.keys.empty()) sc = scale.at(t);
    if (!rotation.keys.empty()) q = rotation.at(t);
    return trs(tr, q, sc);
  }
};

struct AnimTriangle {
  int node;
  std::uint32_t material;
  std::vector<std::pair<double, Triangle>> keys;  // ascending times, linear in between
};

}  // namespace

struct AffScene::Data {
  std::string path;  // of the top file, for errors found when the scene is evaluated
  struct Node {
    int parent = -1;
    Affine fixed;           // `xs`
    std::string animation;  // `x NAME` (empty: fixed)
  };
  std::vector<Node> nodes{Node{}};  // 0 = the world
  std::map<std::string, Keyframes> keyframes;
  std::vector<Triangle> triangles;  // local space
  std::vector<int> triangle_node;
  std::vector<std::uint32_t> triangle_material;
  std::vector<AnimTriangle> animated;
  std::vector<Material> materials{Material{}};  // 0: before any f / fm
  std::uint32_t current_material = 0;
  std::vector<Light> lights;
  std::optional<Vec3> background, ambient;
  struct View {
    Vec3 from{0, 0, 1}, at{0, 0, 0}, up{0, 1, 0};
    float angle = 45;
  };
  std::optional<View> view;
};

namespace {

// Tokens of one file with line numbers; `%` and `#` start a comment to the end of the line.
class Lexer {
 public:
  // `quote`: errors may quote the file's words. Not for included files: an include may name
  // any file on the machine, and an error must not show its content.
  Lexer(std::string path, std::string text, bool quote)
      : path_(std::move(path)), text_(std::move(text)), quote_(quote) {}

  bool next(std::string& token) {
    skip();
    if (pos_ >= text_.size()) return false;
    token_line_ = line_;
    const std::size_t start = pos_;
    if (text_[pos_] == '{' || text_[pos_] == '}') {
      ++pos_;
    } else {
      while (pos_ < text_.size() && !std::isspace(static_cast<unsigned char>(text_[pos_])) &&
             text_[pos_] != '%' && text_[pos_] != '#' && text_[pos_] != '{' && text_[pos_] != '}')
        ++pos_;
    }
    token.assign(text_, start, pos_ - start);
    return true;
  }
  std::string word(const char* what) {
    std::string t;
    if (!next(t)) fail(std::string("the file ends where ") + what + " should be");
    return t;
  }
  // The next token if it is `word` (consumed), else nothing consumed.
  bool accept(const std::string& word) {
    const std::size_t pos = pos_, line = line_;
    std::string t;
    if (next(t) && t == word) return true;
    pos_ = pos, line_ = line;
    return false;
  }
  std::string peek() {
    const std::size_t pos = pos_, line = line_;
    std::string t;
    if (!next(t)) t.clear();
    pos_ = pos, line_ = line;
    return t;
  }
  double number(const char* what) {
    const std::string t = word(what);
    char* end = nullptr;
    const double v = std::strtod(t.c_str(), &end);
    if (t.empty() || end != t.c_str() + t.size())
      fail(shown(t) + " is not a number (" + what + ")");
    if (!std::isfinite(v)) fail(std::string("a non-finite ") + what);
    return v;
  }
  std::size_t count(const char* what, std::size_t max = kMaxCount) {
    const double v = number(what);
    if (v < 0 || v != std::floor(v) || v > static_cast<double>(max))
      fail(std::string("bad ") + what + " " + std::to_string(v));
    return static_cast<std::size_t>(v);
  }
  Vec3 vec3(const char* what) {
    Vec3 v;
    for (int i = 0; i < 3; ++i) v[i] = static_cast<float>(number(what));
    return v;
  }
  [[noreturn]] void fail(const std::string& problem) const {
    throw Error(path_ + ":" + std::to_string(token_line_), problem);
  }
  const std::string& path() const { return path_; }
  // A word of the file for an error message: quoted (cut to 40 characters), or not shown.
  std::string shown(const std::string& word) const {
    return quote_ ? "'" + word.substr(0, 40) + "'" : "a word (not shown: an included file)";
  }

 private:
  void skip() {
    while (pos_ < text_.size()) {
      const char c = text_[pos_];
      if (c == '\n') {
        ++line_;
        ++pos_;
      } else if (std::isspace(static_cast<unsigned char>(c))) {
        ++pos_;
      } else if (c == '%' || c == '#') {
        while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
      } else {
        break;
      }
    }
  }
  std::string path_, text_;
  bool quote_ = true;
  std::size_t pos_ = 0, line_ = 1, token_line_ = 1;
};

class Parser {
 public:
  Parser(AffScene::Data& data, AffAnimation& animation) : data_(data), animation_(animation) {}

  void parse_file(const std::string& path, int node, int depth) {
    if (depth == 0) {
      std::error_code ec;
      root_ = std::filesystem::weakly_canonical(std::filesystem::absolute(path), ec).parent_path();
    }
    const Bytes bytes = read_maybe_gzipped(path);
    if (depth > 0) {
      bytes_ += bytes.size();
      if (bytes_ > kMaxIncludedBytes)
        throw Error(path, "the included files hold more than the limit of " +
                              std::to_string(kMaxIncludedBytes >> 20) + " MiB in all");
    }
    Lexer lex(path, std::string(bytes.begin(), bytes.end()), depth == 0);
    parse_block(lex, node, depth, false);
  }

 private:
  void add(Lexer& lex, int node, const Triangle& t) {
    if (data_.triangles.size() + data_.animated.size() >= kMaxTriangles)
      lex.fail("too many triangles");
    data_.triangles.push_back(t);
    data_.triangle_node.push_back(node);
    data_.triangle_material.push_back(data_.current_material);
  }

  // Statements until the end of the file, or until `}` when `braced`.
  void parse_block(Lexer& lex, int node, int depth, bool braced) {
    std::string t;
    while (lex.next(t)) {
      if (t == "}") {
        if (!braced) lex.fail("'}' without a matching '{'");
        return;
      }
      statement(lex, t, node, depth);
    }
    if (braced) lex.fail("the file ends inside a '{' block (missing '}')");
  }

  // The block of the transform node just added, nested one level deeper.
  void nested_block(Lexer& lex, int depth) {
    if (++blocks_ > kMaxBlockDepth)
      lex.fail("transform blocks nested deeper than the limit of " +
               std::to_string(kMaxBlockDepth) + " levels");
    parse_block(lex, static_cast<int>(data_.nodes.size() - 1), depth, true);
    --blocks_;
  }

  // The limits of includes, and that an include stays inside the scene's folder (it may not
  // read other files of the machine: ../../etc/passwd, an absolute path, a link out).
  void check_include(Lexer& lex, const std::string& file, const std::string& included, int depth) {
    if (depth + 1 > kMaxIncludeDepth)
      lex.fail("includes nested deeper than the limit of " + std::to_string(kMaxIncludeDepth) +
               " levels (a file that includes itself?)");
    if (++files_ > kMaxIncludedFiles)
      lex.fail("more than the limit of " + std::to_string(kMaxIncludedFiles) +
               " included files in all (files that include each other repeatedly?)");
    if (!inside_folder(root_, included))
      lex.fail("the include " + lex.shown(file) + " lies outside the scene's folder " +
               root_.string() + "; refusing to read it");
  }

  void expect_open(Lexer& lex) {
    if (lex.word("'{'") != "{") lex.fail("expected '{'");
  }

  void statement(Lexer& lex, const std::string& t, int node, int depth) {
    if (t == "v") return view(lex);
    if (t == "b") return void(data_.background = colour(lex, "background colour"));
    if (t == "am") return void(data_.ambient = colour(lex, "ambient colour"));
    if (t == "l") return light(lex);
    if (t == "la") {
      lex.word("light name");
      return light(lex);
    }
    if (t == "f") return fill(lex, false);
    if (t == "fm") return fill(lex, true);
    if (t == "a") {
      animation_.start = lex.number("animation start");
      animation_.end = lex.number("animation end");
      animation_.frames = static_cast<int>(lex.count("frame count", 1 << 20));
      if (!(animation_.end >= animation_.start)) lex.fail("the animation ends before it starts");
      return;
    }
    if (t == "i") {
      lex.number("detail level");
      const std::string file = lex.word("include file name");
      const std::filesystem::path base = std::filesystem::path(lex.path()).parent_path();
      const std::string included = (base / file).string();
      check_include(lex, file, included, depth);
      return parse_file(included, node, depth + 1);
    }
    if (t == "p" || t == "pp") return polygon(lex, node, t == "pp");
    if (t == "tt" || t == "ttp") {
      lex.word("texture name");
      Vec3 v[3];
      for (auto& p : v) {
        p = lex.vec3("vertex");
        skip_numbers(lex, t == "tt" ? 2 : 5, "vertex attribute");
      }
      return add(lex, node, {v[0], v[1], v[2]});
    }
    if (t == "s") return sphere(lex, node);
    if (t == "c") return cone(lex, node);
    if (t == "m") return mesh(lex, node);
    if (t == "tpa") return animated(lex, node);
    if (t == "k") return keyframes(lex);
    if (t == "xs") {
      const Vec3 s = lex.vec3("scale");
      const Vec3 axis = lex.vec3("rotation axis");
      const double angle = lex.number("rotation angle");
      const Vec3 tr = lex.vec3("translation");
      expect_open(lex);
      AffScene::Data::Node n;
      n.parent = node;
      n.fixed = trs({tr[0], tr[1], tr[2]}, axis_angle(axis[0], axis[1], axis[2], angle),
                    {s[0], s[1], s[2]});
      data_.nodes.push_back(n);
      return nested_block(lex, depth);
    }
    if (t == "x") {
      const std::string name = lex.word("transform name");
      expect_open(lex);
      AffScene::Data::Node n;
      n.parent = node;
      n.animation = name;
      data_.nodes.push_back(n);
      return nested_block(lex, depth);
    }
    if (t == "{") lex.fail("'{' without a transform before it");
    lex.fail("unknown statement " + lex.shown(t));
  }

  void skip_numbers(Lexer& lex, int n, const char* what) {
    for (int i = 0; i < n; ++i) lex.number(what);
  }

  static Vec3 colour(Lexer& lex, const char* what) {
    const Vec3 c = lex.vec3(what);
    if (c.x < 0 || c.y < 0 || c.z < 0) lex.fail(std::string("a negative ") + what);
    return c;
  }

  // f R G B Kd Ks Shine T ior (NFF) or fm ambient(3) diffuse(3) specular(3) Shine T ior.
  void fill(Lexer& lex, bool extended) {
    Material m;
    if (extended) {
      m.ambient = colour(lex, "ambient colour");
      m.diffuse = colour(lex, "diffuse colour");
      m.specular = colour(lex, "specular colour");
    } else {
      const Vec3 c = colour(lex, "colour");
      const double kd = lex.number("Kd"), ks = lex.number("Ks");
      if (kd < 0 || ks < 0) lex.fail("negative Kd or Ks");
      m.diffuse = c * static_cast<float>(kd);
      m.specular = Vec3{static_cast<float>(ks)};
    }
    const double shine = lex.number("Shine"), t = lex.number("transmittance"),
                 ior = lex.number("index of refraction");
    if (!(t >= 0 && t <= 1)) lex.fail("the transmittance must lie in [0, 1]");
    m.shininess = static_cast<float>(std::clamp(shine, 1.0, 1e6));
    m.transparency = static_cast<float>(t);
    m.ior = ior >= 1e-3 && ior <= 100 ? static_cast<float>(ior) : 1.0f;
    m.name = "aff " + std::to_string(data_.materials.size());
    data_.materials.push_back(m);
    data_.current_material = static_cast<std::uint32_t>(data_.materials.size() - 1);
  }

  void view(Lexer& lex) {
    AffScene::Data::View v;
    for (;;) {
      const std::string w = lex.peek();
      if (w == "from" || w == "at" || w == "up") {
        lex.accept(w);
        const Vec3 value = lex.vec3(w.c_str());
        (w == "from" ? v.from : w == "at" ? v.at : v.up) = value;
      } else if (w == "angle") {
        lex.accept(w);
        const double angle = lex.number("angle");
        if (!(angle > 0 && angle < 180)) lex.fail("the view angle must lie in (0, 180) degrees");
        v.angle = static_cast<float>(angle);
      } else if (w == "hither") {
        lex.accept(w);
        lex.number(w.c_str());
      } else if (w == "resolution") {
        lex.accept(w);
        lex.count("resolution", 1 << 16);
        lex.count("resolution", 1 << 16);
      } else {
        if (v.from == v.at) lex.fail("the view's from and at are the same point");
        data_.view = v;
        return;
      }
    }
  }

  void light(Lexer& lex) {
    Light light;
    light.kind = Light::Kind::point;
    light.falloff = false;
    light.position = lex.vec3("light position");
    // An optional colour: three more numbers on the statement.
    const std::string w = lex.peek();
    char* end = nullptr;
    std::strtod(w.c_str(), &end);
    if (!w.empty() && end == w.c_str() + w.size()) light.color = colour(lex, "light colour");
    data_.lights.push_back(light);
  }

  void polygon(Lexer& lex, int node, bool normals) {
    const std::size_t n = lex.count("vertex count");
    if (n < 3) lex.fail("a polygon needs at least 3 vertices");
    std::vector<Vec3> v(n);
    for (auto& p : v) {
      p = lex.vec3("vertex");
      if (normals) lex.vec3("normal");
    }
    for (std::size_t i = 1; i + 1 < n; ++i) add(lex, node, {v[0], v[i], v[i + 1]});  // a fan
  }

  void sphere(Lexer& lex, int node) {
    const Vec3 c = lex.vec3("sphere centre");
    const double r = lex.number("sphere radius");
    if (!(r >= 0)) lex.fail("negative sphere radius");
    const auto point = [&](int ring, int seg) {
      const double theta = std::numbers::pi * ring / kSphereRings;
      const double phi = 2 * std::numbers::pi * seg / kSphereSegments;
      return Vec3{static_cast<float>(c[0] + r * std::sin(theta) * std::cos(phi)),
                  static_cast<float>(c[1] + r * std::cos(theta)),
                  static_cast<float>(c[2] + r * std::sin(theta) * std::sin(phi))};
    };
    for (int i = 0; i < kSphereRings; ++i)
      for (int j = 0; j < kSphereSegments; ++j) {
        const Vec3 a = point(i, j), b = point(i + 1, j), cc = point(i + 1, j + 1),
                   d = point(i, j + 1);
        if (i + 1 < kSphereRings) add(lex, node, {a, b, cc});
        if (i > 0) add(lex, node, {a, cc, d});
      }
  }

  void cone(Lexer& lex, int node) {
    const Vec3 base = lex.vec3("cone base");
    const double rb = lex.number("cone base radius");
    const Vec3 apex = lex.vec3("cone apex");
    const double ra = lex.number("cone apex radius");
    if (!(rb >= 0 && ra >= 0)) lex.fail("negative cone radius");
    const Vec3 axis = apex - base;
    if (!(length(axis) > 0)) lex.fail("cone with coincident base and apex");
    const Vec3 w = normalize(axis);
    const Vec3 helper = std::abs(w[0]) < 0.9f ? Vec3{1, 0, 0} : Vec3{0, 1, 0};
    const Vec3 u = normalize(cross(w, helper)), v = cross(w, u);
    const auto ring = [&](const Vec3& centre, double r, int k) {
      const double phi = 2 * std::numbers::pi * k / kConeSegments;
      const float cu = static_cast<float>(r * std::cos(phi)),
                  sv = static_cast<float>(r * std::sin(phi));
      return centre + u * cu + v * sv;
    };
    for (int k = 0; k < kConeSegments; ++k) {
      const Vec3 b0 = ring(base, rb, k), b1 = ring(base, rb, k + 1);
      const Vec3 a0 = ring(apex, ra, k), a1 = ring(apex, ra, k + 1);
      add(lex, node, {b0, b1, a1});
      add(lex, node, {b0, a1, a0});
    }
  }

  void mesh(Lexer& lex, int node) {
    std::vector<Vec3> vertices;
    std::size_t normals = 0, texcoords = 0;
    for (;;) {
      const std::string w = lex.word("mesh section");
      if (w == "vertices") {
        vertices.resize(lex.count("vertex count"));
        for (auto& p : vertices) p = lex.vec3("vertex");
      } else if (w == "normals") {
        normals = lex.count("normal count");
        skip_numbers_n(lex, normals * 3, "normal");
      } else if (w == "texturecoords") {
        texcoords = lex.count("texture coordinate count");
        lex.word("texture name");
        skip_numbers_n(lex, texcoords * 2, "texture coordinate");
      } else if (w == "triangles") {
        const std::size_t n = lex.count("triangle count");
        for (std::size_t i = 0; i < n; ++i) {
          std::size_t idx[3];
          for (auto& k : idx) {
            k = lex.count("vertex index");
            if (k >= vertices.size())
              lex.fail("vertex index " + std::to_string(k) + " out of range");
          }
          if (normals) skip_index(lex, normals, "normal index");
          if (texcoords) skip_index(lex, texcoords, "texture coordinate index");
          add(lex, node, {vertices[idx[0]], vertices[idx[1]], vertices[idx[2]]});
        }
        return;
      } else {
        lex.fail("unknown mesh section " + lex.shown(w) +
                 " (vertices, normals, texturecoords, triangles)");
      }
    }
  }
  void skip_numbers_n(Lexer& lex, std::size_t n, const char* what) {
    for (std::size_t i = 0; i < n; ++i) lex.number(what);
  }
  void skip_index(Lexer& lex, std::size_t n, const char* what) {
    for (int c = 0; c < 3; ++c)
      if (lex.count(what) >= n) lex.fail(std::string(what) + " out of range");
  }

  void animated(Lexer& lex, int node) {
    const std::size_t n = lex.count("key count");
    if (n < 1) lex.fail("an animated triangle needs at least one key");
    AnimTriangle a;
    a.node = node;
    a.material = data_.current_material;
    for (std::size_t i = 0; i < n; ++i) {
      const double time = lex.number("key time");
      if (!a.keys.empty() && !(time > a.keys.back().first))
        lex.fail("animated triangle key times must increase");
      Vec3 v[3];
      for (auto& p : v) {
        p = lex.vec3("vertex");
        lex.vec3("normal");
      }
      a.keys.push_back({time, {v[0], v[1], v[2]}});
    }
    if (data_.triangles.size() + data_.animated.size() >= kMaxTriangles)
      lex.fail("too many triangles");
    data_.animated.push_back(std::move(a));
  }

  template <int D, typename Read>
  void spline_keys(Lexer& lex, KbSpline<D>& spline, Read read) {
    const std::size_t n = lex.count("key count");
    if (n < 1) lex.fail("a key-frame track needs at least one key");
    spline.keys.clear();
    for (std::size_t i = 0; i < n; ++i) {
      typename KbSpline<D>::Key k;
      k.time = lex.number("key time");
      k.value = read();
      k.tension = lex.number("tension");
      k.continuity = lex.number("continuity");
      k.bias = lex.number("bias");
      spline.keys.push_back(k);
    }
    // BART's files repeat a time or go back in time now and then: order the keys by time,
    // the later key of one time winning.
    std::stable_sort(spline.keys.begin(), spline.keys.end(),
                     [](const auto& a, const auto& b) { return a.time < b.time; });
    std::vector<typename KbSpline<D>::Key> unique;
    for (const auto& k : spline.keys) {
      if (!unique.empty() && unique.back().time == k.time) unique.pop_back();
      unique.push_back(k);
    }
    spline.keys = std::move(unique);
  }

  void keyframes(Lexer& lex) {
    const std::string name = lex.word("key-frame name");
    expect_open(lex);
    Keyframes k;
    for (;;) {
      const std::string w = lex.word("'transl', 'rot', 'scale' or '}'");
      if (w == "}") break;
      if (w == "transl" || w == "scale") {
        spline_keys<3>(lex, w == "transl" ? k.translation : k.scale, [&] {
          const Vec3 v = lex.vec3(w.c_str());
          return std::array<double, 3>{v[0], v[1], v[2]};
        });
      } else if (w == "rot") {
        spline_keys<4>(lex, k.rotation, [&] {
          const Vec3 axis = lex.vec3("rotation axis");
          return axis_angle(axis[0], axis[1], axis[2], lex.number("rotation angle"));
        });
        // Neighbouring quaternions in one hemisphere, so the spline takes the short way.
        for (std::size_t i = 1; i < k.rotation.keys.size(); ++i) {
          const Quat& p = k.rotation.keys[i - 1].value;
          Quat& q = k.rotation.keys[i].value;
          if (p[0] * q[0] + p[1] * q[1] + p[2] * q[2] + p[3] * q[3] < 0)
            for (double& c : q) c = -c;
        }
      } else {
        lex.fail("unknown key-frame track " + lex.shown(w) + " (transl, rot, scale)");
      }
    }
    data_.keyframes[name] = std::move(k);
  }

  AffScene::Data& data_;
  std::filesystem::path root_;  // the folder of the scene: includes stay inside it
  std::size_t files_ = 0, bytes_ = 0;
  int blocks_ = 0;
  AffAnimation& animation_;
};

}  // namespace

AffScene::AffScene() : data_(std::make_unique<Data>()) {}
AffScene::~AffScene() = default;
AffScene::AffScene(AffScene&&) noexcept = default;
AffScene& AffScene::operator=(AffScene&&) noexcept = default;

AffScene AffScene::load(const std::string& path) {
  AffScene scene;
  scene.data_->path = path;
  Parser(*scene.data_, scene.animation_).parse_file(path, 0, 0);
  if (scene.triangle_count() == 0) throw Error(path, "the scene has no triangles");
  return scene;
}

std::size_t AffScene::triangle_count() const {
  return data_->triangles.size() + data_->animated.size();
}

std::vector<Triangle> AffScene::triangles_at(double t) const {
  const Data& d = *data_;
  std::vector<Affine> world(d.nodes.size());
  for (std::size_t i = 1; i < d.nodes.size(); ++i) {  // parents come before children
    const Data::Node& n = d.nodes[i];
    // A transform without key frames (BART's robots have one) stays the identity.
    const auto k = n.animation.empty() ? d.keyframes.end() : d.keyframes.find(n.animation);
    const Affine local = k == d.keyframes.end() ? n.fixed : k->second.at(t);
    world[i] = world[static_cast<std::size_t>(n.parent)] * local;
  }
  std::vector<Triangle> out;
  out.reserve(triangle_count());
  for (std::size_t i = 0; i < d.triangles.size(); ++i) {
    const Affine& m = world[static_cast<std::size_t>(d.triangle_node[i])];
    const Triangle& tri = d.triangles[i];
    out.push_back({m.apply(tri.v0), m.apply(tri.v1), m.apply(tri.v2)});
  }
  for (const AnimTriangle& a : d.animated) {
    Triangle tri = a.keys.front().second;
    if (t >= a.keys.back().first) {
      tri = a.keys.back().second;
    } else if (t > a.keys.front().first) {
      std::size_t k = 0;
      while (t >= a.keys[k + 1].first) ++k;
      const double u = (t - a.keys[k].first) / (a.keys[k + 1].first - a.keys[k].first);
      const Triangle &p = a.keys[k].second, &q = a.keys[k + 1].second;
      const float f = static_cast<float>(u);
      tri = {p.v0 + (q.v0 - p.v0) * f, p.v1 + (q.v1 - p.v1) * f, p.v2 + (q.v2 - p.v2) * f};
    }
    const Affine& m = world[static_cast<std::size_t>(a.node)];
    out.push_back({m.apply(tri.v0), m.apply(tri.v1), m.apply(tri.v2)});
  }
  // Sizes, transforms and key frames may each be valid and still move a vertex beyond the
  // limit within which splitray traces exactly (a sphere of radius 4e20, a scale at time t).
  char when[48];
  std::snprintf(when, sizeof when, " at time %g", t);
  check_triangles(out, d.path + when);
  return out;
}

std::optional<Camera> AffScene::camera_at(double t) const {
  const Data& d = *data_;
  if (!d.view) return std::nullopt;
  Camera camera;
  camera.eye = d.view->from;
  camera.target = d.view->at;
  camera.up = d.view->up;
  camera.vfov_degrees = d.view->angle;
  if (const auto k = d.keyframes.find("camera"); k != d.keyframes.end()) {
    const Affine m = k->second.at(t);
    if (!k->second.translation.keys.empty())
      camera.eye = {static_cast<float>(m.m[0][3]), static_cast<float>(m.m[1][3]),
                    static_cast<float>(m.m[2][3])};
    Vec3 direction = normalize(camera.target - d.view->from);
    if (!k->second.rotation.keys.empty()) {
      direction = normalize(Vec3{static_cast<float>(-m.m[0][2]), static_cast<float>(-m.m[1][2]),
                                 static_cast<float>(-m.m[2][2])});
      camera.up = {static_cast<float>(m.m[0][1]), static_cast<float>(m.m[1][1]),
                   static_cast<float>(m.m[2][1])};
    }
    camera.target = camera.eye + direction;
  }
  if (length(cross(normalize(camera.target - camera.eye), normalize(camera.up))) < 1e-4f)
    camera.up = std::abs(camera.up.y) < 0.9f ? Vec3{0, 1, 0} : Vec3{0, 0, 1};
  return camera;
}

Scene AffScene::scene_at(double t) const {
  const Data& d = *data_;
  Scene scene;
  Mesh mesh;
  mesh.name = "aff";
  const std::vector<Triangle> triangles = triangles_at(t);
  mesh.positions.reserve(triangles.size() * 3);
  for (const Triangle& tri : triangles) {
    const auto base = static_cast<std::uint32_t>(mesh.positions.size());
    for (int k = 0; k < 3; ++k) mesh.positions.push_back(tri.vertex(k));
    mesh.faces.push_back({base, base + 1, base + 2});
  }
  mesh.materials = d.materials;
  mesh.face_materials = d.triangle_material;
  for (const AnimTriangle& a : d.animated) mesh.face_materials.push_back(a.material);
  scene.meshes.push_back(std::move(mesh));
  scene.instances.push_back(Instance{});
  scene.lights = d.lights;
  scene.lights_fit_view = d.lights.empty();
  if (d.background) scene.background = *d.background;
  if (d.ambient) scene.ambient = *d.ambient;
  scene.camera = camera_at(t);
  if (!scene.camera) scene.camera = Camera::frame(scene.bounds());
  return scene;
}

Scene load_aff_scene(const std::string& path) {
  const AffScene aff = AffScene::load(path);
  return aff.scene_at(aff.animation().frames > 0 ? aff.animation().start : 0.0);
}

}  // namespace splitray

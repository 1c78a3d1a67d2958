#include "splitray/render/shapes.hpp"

#include <cmath>
#include <map>
#include <utility>

#include "splitray/core/errors.hpp"

namespace splitray {

namespace {

void add_quad(Mesh& mesh, const Vec3& origin, const Vec3& u, const Vec3& v) {
  const auto base = static_cast<std::uint32_t>(mesh.positions.size());
  const Vec3 n = normalize(cross(u, v));
  for (const Vec3& p : {origin, origin + u, origin + u + v, origin + v}) {
    mesh.positions.push_back(p);
    mesh.normals.push_back(n);
  }
  mesh.faces.push_back({base, base + 1, base + 2});
  mesh.faces.push_back({base, base + 2, base + 3});
}

}  // namespace

Mesh make_icosphere(int subdivisions) {
  if (subdivisions < 0 || subdivisions > 8)
    throw Error("make_icosphere",
                "subdivisions must be in 0..8, got " + std::to_string(subdivisions));
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  Mesh mesh;
  mesh.name = "icosphere";
  for (const Vec3& p : {Vec3{-1, t, 0}, Vec3{1, t, 0}, Vec3{-1, -t, 0}, Vec3{1, -t, 0},
                        Vec3{0, -1, t}, Vec3{0, 1, t}, Vec3{0, -1, -t}, Vec3{0, 1, -t},
                        Vec3{t, 0, -1}, Vec3{t, 0, 1}, Vec3{-t, 0, -1}, Vec3{-t, 0, 1}})
    mesh.positions.push_back(normalize(p));
  mesh.faces = {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
                {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int level = 0; level < subdivisions; ++level) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> midpoints;
    auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
      const auto key = std::minmax(a, b);
      const auto [it, inserted] = midpoints.try_emplace(key, 0);
      if (inserted) {
        it->second = static_cast<std::uint32_t>(mesh.positions.size());
        mesh.positions.push_back(normalize(mesh.positions[a] + mesh.positions[b]));
      }
      return it->second;
    };
    std::vector<std::array<std::uint32_t, 3>> faces;
    faces.reserve(mesh.faces.size() * 4);
    for (const auto& f : mesh.faces) {
      const std::uint32_t ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]),
                          ca = midpoint(f[2], f[0]);
      faces.push_back({f[0], ab, ca});
      faces.push_back({f[1], bc, ab});
      faces.push_back({f[2], ca, bc});
      faces.push_back({ab, bc, ca});
    }
    mesh.faces = std::move(faces);
  }
  mesh.normals = mesh.positions;
  return mesh;
}

Mesh make_quad(const Vec3& origin, const Vec3& u, const Vec3& v) {
  Mesh mesh;
  mesh.name = "quad";
  add_quad(mesh, origin, u, v);
  return mesh;
}

Mesh make_checker(const Vec3& origin, const Vec3& u, const Vec3& v, int n, int parity) {
  if (n < 1) throw Error("make_checker", "the grid needs at least one tile per side");
  Mesh mesh;
  mesh.name = "checker";
  const Vec3 du = u / static_cast<float>(n), dv = v / static_cast<float>(n);
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      if ((i + j) % 2 == parity)
        add_quad(mesh, origin + du * static_cast<float>(i) + dv * static_cast<float>(j), du, dv);
  return mesh;
}

Mesh make_box(const Vec3& lo, const Vec3& hi) {
  Mesh mesh;
  mesh.name = "box";
  const Vec3 e = hi - lo;
  const Vec3 x{e.x, 0, 0}, y{0, e.y, 0}, z{0, 0, e.z};
  add_quad(mesh, lo, y, x);      // -z
  add_quad(mesh, lo + z, x, y);  // +z
  add_quad(mesh, lo, z, y);      // -x
  add_quad(mesh, lo + x, y, z);  // +x
  add_quad(mesh, lo, x, z);      // -y
  add_quad(mesh, lo + y, z, x);  // +y
  return mesh;
}

}  // namespace splitray

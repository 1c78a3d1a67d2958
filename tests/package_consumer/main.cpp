// Loads a mesh given on the command line, builds a kd-tree and casts one ray down the middle
// of its bounds; exits 0 when the kd-tree and brute force agree on the hit.
#include <cstdio>

#include "splitray/accel/accel.hpp"
#include "splitray/io/mesh_io.hpp"

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  try {
    const splitray::Mesh mesh = splitray::load_mesh(argv[1]);
    const auto triangles = mesh.triangles();
    const auto kd = splitray::make_accel("kd", triangles);
    const auto brute = splitray::make_accel("brute", triangles);
    const splitray::Aabb box = mesh.bounds();
    const splitray::Vec3 c = box.center();
    const splitray::Ray ray{{c.x, c.y, box.hi.z + 1}, {0, 0, -1}};
    const splitray::Hit a = kd->intersect(ray), b = brute->intersect(ray);
    std::printf("hit %d prim %u t %g\n", a.found() ? 1 : 0, a.prim, a.t);
    return a.prim == b.prim && a.t == b.t ? 0 : 1;
  } catch (const splitray::Error& e) {  // declared by mesh_io.hpp's own includes
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
}

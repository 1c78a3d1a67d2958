// splitray from your own program (built against the installed package: examples/cpp/
// CMakeLists.txt). Loads a mesh, hands its vertex and index arrays to a MeshScene as strided
// buffers (no copy into triangles by the caller), casts rays down the mesh's bounds and checks
// every hit against brute force. Exits 0 when all agree.
#include <cstdio>
#include <vector>

#include "splitray/splitray.hpp"  // the whole public API

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s MESH\n", argv[0]);
    return 2;
  }
  try {
    const splitray::Mesh mesh = splitray::load_mesh(argv[1]);
    // The mesh as an application holds it: positions (12-byte rows) and index triples.
    const splitray::MeshBuffers buffers{mesh.positions.data(),  mesh.positions.size(),
                                        sizeof(splitray::Vec3), mesh.faces.data(),
                                        mesh.faces.size(),      sizeof(mesh.faces[0])};
    const splitray::MeshScene bvh(buffers, "bvh"), brute(buffers, "brute");
    const splitray::Aabb box = mesh.bounds();
    std::vector<splitray::Ray> rays;
    for (int i = 0; i < 32; ++i)
      for (int j = 0; j < 32; ++j) {
        const float x = box.lo.x + (box.hi.x - box.lo.x) * (i + 0.5f) / 32;
        const float y = box.lo.y + (box.hi.y - box.lo.y) * (j + 0.5f) / 32;
        rays.push_back({{x, y, box.hi.z + 1}, {0, 0, -1}});
      }
    std::vector<splitray::SurfaceHit> hits(rays.size()), expected(rays.size());
    bvh.intersect(rays, hits);
    brute.intersect(rays, expected);
    int found = 0, wrong = 0;
    for (std::size_t r = 0; r < rays.size(); ++r) {
      found += hits[r].found();
      wrong += hits[r].prim != expected[r].prim || hits[r].t != expected[r].t ||
               !(hits[r].ng == expected[r].ng);
    }
    std::printf("%d of %zu rays hit, %d differ from brute force\n", found, rays.size(), wrong);
    return wrong == 0 && found > 0 ? 0 : 1;
  } catch (const splitray::Error& e) {  // declared by the headers' own includes
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
}

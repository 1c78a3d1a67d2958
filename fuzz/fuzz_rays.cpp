// libFuzzer target: ray queries on a fuzzed mesh. The bytes give a small triangle soup on an
// integer grid (shared vertices, edges, coplanar and degenerate triangles come naturally),
// build settings and rays (free, or aimed at a vertex, an edge or a centroid, axis-parallel,
// short segments). Every structure with every builder must give brute force's answers
// bit for bit (same triangle, t, u, v; same occlusion), also after a refit to a deformed copy
// of the mesh. Embree, with its own triangle test, must report real hits in [tmin, tmax] and
// find the triangles brute force hits well inside, seen not edge-on. Any exception other than
// splitray::Error, and any mismatch, aborts.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "fuzz_input.hpp"
#include "splitray/accel/accel.hpp"

namespace {

using namespace splitray;

class Bytes {
 public:
  Bytes(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool empty() const { return pos_ >= size_; }
  std::uint8_t byte() { return pos_ < size_ ? data_[pos_++] : 0; }
  // A grid coordinate in [-8, 8) in steps of 1/16.
  float coord() { return static_cast<float>(static_cast<std::int8_t>(byte())) / 16.0f; }
  Vec3 point() {
    const float x = coord(), y = coord();
    return {x, y, coord()};
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_, pos_ = 0;
};

std::vector<Ray> make_rays(Bytes& in, const std::vector<Triangle>& tris, std::size_t count) {
  std::vector<Ray> rays;
  for (std::size_t i = 0; i < count && !in.empty(); ++i) {
    const std::uint8_t kind = in.byte();
    const Triangle& tri = tris[in.byte() % tris.size()];
    Ray ray;
    ray.org = in.point() * 1.5f;  // also outside the mesh's bounds
    const int k = kind / 8 % 3;
    switch (kind % 8) {
      case 0:
        ray.dir = in.point();
        break;
      case 1:
        ray.dir = tri.vertex(k) - ray.org;
        break;
      case 2:
        ray.dir = (tri.vertex(k) + tri.vertex((k + 1) % 3)) * 0.5f - ray.org;
        break;
      case 3:
        ray.dir = (tri.v0 + tri.v1 + tri.v2) * (1.0f / 3) - ray.org;
        break;
      case 4:
        ray.dir = Vec3{0.0f};
        ray.dir[k] = (kind & 64) ? 1.0f : -1.0f;
        break;
      case 5:  // in the plane of a vertex, parallel to an axis plane
        ray.org[k] = tri.vertex(kind / 32 % 3)[k];
        ray.dir = in.point();
        ray.dir[k] = (kind & 128) ? 0.0f : -0.0f;
        break;
      default:  // a segment toward a vertex that may stop short of it or start past it
        ray.dir = tri.vertex(k) - ray.org;
        ray.tmin = static_cast<float>(in.byte()) / 256.0f;
        ray.tmax = ray.tmin + static_cast<float>(in.byte()) / 128.0f;
        break;
    }
    if (!(ray.dir.x != 0 || ray.dir.y != 0 || ray.dir.z != 0)) ray.dir = {0.25f, 1, 0.5f};
    rays.push_back(ray);
  }
  return rays;
}

bool same_hit(const Hit& a, const Hit& b) {
  return a.prim == b.prim &&
         std::bit_cast<std::uint32_t>(a.t) == std::bit_cast<std::uint32_t>(b.t) &&
         std::bit_cast<std::uint32_t>(a.u) == std::bit_cast<std::uint32_t>(b.u) &&
         std::bit_cast<std::uint32_t>(a.v) == std::bit_cast<std::uint32_t>(b.v);
}

std::string describe(const Ray& r) {
  char text[256];
  std::snprintf(text, sizeof text, "org (%a %a %a) dir (%a %a %a) t [%a, %a]", r.org.x, r.org.y,
                r.org.z, r.dir.x, r.dir.y, r.dir.z, r.tmin, r.tmax);
  return text;
}

std::string describe(const Hit& h) {
  if (!h.found()) return "miss";
  char text[128];
  std::snprintf(text, sizeof text, "prim %u t %a u %a v %a", h.prim, h.t, h.u, h.v);
  return text;
}

// Exact structures: brute force's answers bit for bit.
void expect_exact(const Accel& accel, const Accel& brute, const std::vector<Ray>& rays,
                  const std::string& what) {
  for (const Ray& ray : rays) {
    const Hit got = accel.intersect(ray), want = brute.intersect(ray);
    if (!same_hit(got, want))
      fuzz::finding(what + ": ray " + describe(ray) + ": " + describe(got) + ", brute force " +
                    describe(want));
    if (accel.occluded(ray) != brute.occluded(ray))
      fuzz::finding(what + ": occluded differs from brute force for ray " + describe(ray));
  }
}

// Embree: a hit lies in [tmin, tmax] on a real triangle; a hit of brute force well inside a
// triangle seen not edge-on is found (at a t no farther than brute force's, within rounding).
void expect_close(const Accel& embree, const Accel& brute, const std::vector<Triangle>& tris,
                  const std::vector<Ray>& rays, const std::string& what) {
  for (const Ray& ray : rays) {
    const Hit got = embree.intersect(ray), want = brute.intersect(ray);
    if (got.found() && (got.prim >= tris.size() || !(got.t >= ray.tmin * (1 - 1e-5f)) ||
                        !(got.t <= ray.tmax * (1 + 1e-5f))))
      fuzz::finding(what + ": ray " + describe(ray) + ": impossible hit " + describe(got));
    if (!want.found()) continue;
    const Triangle& tri = tris[want.prim];
    const Vec3 n = tri.geometric_normal();
    const float cosine = std::abs(dot(n, ray.dir)) / (length(n) * length(ray.dir));
    const float inner = std::min({want.u, want.v, 1 - want.u - want.v});
    // !(cosine >= ...): a degenerate triangle's zero normal gives NaN, and only the watertight
    // test hits those (a ray through the segment they collapse to).
    if (inner < 1e-3f || !(cosine >= 1e-2f) || want.t < ray.tmin + 1e-3f ||
        want.t > ray.tmax - 1e-3f)
      continue;
    if (!got.found() || got.t > want.t * (1 + 1e-4f) + 1e-5f)
      fuzz::finding(what + ": ray " + describe(ray) + ": " + describe(got) +
                    ", brute force finds " + describe(want));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Bytes in(data, size);
  const std::size_t count = 1 + in.byte() % 48;
  BuildConfig config;
  config.threads = 1;
  config.max_leaf_prims = 1 + in.byte() % 4;
  config.bins = 4 + in.byte() % 29;   // 4 to 32: what every binned builder takes
  config.max_depth = in.byte() % 24;  // 0 = automatic
  std::vector<Triangle> tris;
  for (std::size_t i = 0; i < count && !in.empty(); ++i) {
    const Vec3 a = in.point(), b = in.point();
    tris.push_back({a, b, in.point()});
  }
  if (tris.empty()) return 0;
  const std::vector<Ray> rays = make_rays(in, tris, 64);
  // The deformed copy for refit: every vertex moved by up to 1/2 along each axis.
  std::vector<Triangle> moved = tris;
  for (Triangle& t : moved)
    for (Vec3* v : {&t.v0, &t.v1, &t.v2}) *v = *v + in.point() * (1.0f / 16);

  std::unique_ptr<Accel> brute = make_accel("brute", tris, config);
  std::unique_ptr<Accel> brute_moved = make_accel("brute", moved, config);
  for (const std::string& name : accel_names()) {
    if (name == "brute") continue;
    for (const std::string& builder : builder_names(name)) {
      BuildConfig c = config;
      c.builder = builder;
      const std::string what = name + " --builder " + builder;
      std::unique_ptr<Accel> accel;
      try {
        accel = make_accel(name, tris, c);
      } catch (const Error& e) {
        fuzz::finding(what + ": refused a valid mesh: " + e.what());
      }
      if (name == "embree") {
        expect_close(*accel, *brute, tris, rays, what);
        if (accel->refit(moved)) expect_close(*accel, *brute_moved, moved, rays, what + " refit");
      } else {
        expect_exact(*accel, *brute, rays, what);
        if (accel->refit(moved)) expect_exact(*accel, *brute_moved, rays, what + " refit");
      }
    }
  }
  return 0;
}

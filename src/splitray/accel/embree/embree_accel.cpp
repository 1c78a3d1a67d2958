#include "splitray/accel/embree/embree_accel.hpp"

#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <mutex>
#include <string>

#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"
#include "splitray/core/timer.hpp"

namespace splitray {

namespace {

// Scene and geometry quality of a builder name; refit needs Embree's two-level LOW scene,
// the only one that uses the geometry's REFIT quality. "-robust" adds RTC_SCENE_FLAG_ROBUST:
// conservative box tests and Embree's Pluecker triangle test, the guarantee nearest to that of
// our structures (the plain qualities, Embree's defaults, are the yardstick of the targets).
// Embree 3 builds robust scenes with its medium (or, for LOW, its dynamic) builder whatever the
// quality, so there is no high-robust.
struct Quality {
  RTCBuildQuality scene, geometry;
  bool dynamic = false, robust = false;
};

Quality parse_quality(const std::string& builder) {
  if (builder == "low") return {RTC_BUILD_QUALITY_LOW, RTC_BUILD_QUALITY_LOW};
  if (builder == "high") return {RTC_BUILD_QUALITY_HIGH, RTC_BUILD_QUALITY_HIGH};
  if (builder == "medium" || builder.empty())
    return {RTC_BUILD_QUALITY_MEDIUM, RTC_BUILD_QUALITY_MEDIUM};
  if (builder == "refit") return {RTC_BUILD_QUALITY_LOW, RTC_BUILD_QUALITY_REFIT, true};
  if (builder == "low-robust") return {RTC_BUILD_QUALITY_LOW, RTC_BUILD_QUALITY_LOW, false, true};
  if (builder == "medium-robust")
    return {RTC_BUILD_QUALITY_MEDIUM, RTC_BUILD_QUALITY_MEDIUM, false, true};
  throw Error("--builder",
              "'" + builder +
                  "' is not a builder of --accel embree (known: medium, low, high, refit, "
                  "medium-robust, low-robust; Embree builds robust scenes at medium quality at "
                  "most)");
}

const char* error_name(RTCError code) {
  switch (code) {
    case RTC_ERROR_NONE:
      return "no error";
    case RTC_ERROR_INVALID_ARGUMENT:
      return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION:
      return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY:
      return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU:
      return "unsupported CPU";
    case RTC_ERROR_CANCELLED:
      return "cancelled";
    default:
      return "unknown error";
  }
}

// Embree reports errors through a callback from inside its C API, where throwing is not
// allowed: the first message is recorded here and thrown as an Error after the call returns.
struct DeviceState {
  std::mutex mutex;
  std::string error;
  std::atomic<std::int64_t> bytes{0};  // current allocation, from the memory monitor
};

void on_error(void* user, RTCError code, const char* message) {
  auto* state = static_cast<DeviceState*>(user);
  const std::lock_guard lock(state->mutex);
  if (state->error.empty())
    state->error = std::string(error_name(code)) + (message ? std::string(": ") + message : "");
}

bool on_memory(void* user, ssize_t bytes, bool /*post*/) {
  static_cast<DeviceState*>(user)->bytes += bytes;
  return true;  // never veto an allocation
}

void fill_ray(const Ray& ray, RTCRay& out) {
  out.org_x = ray.org.x;
  out.org_y = ray.org.y;
  out.org_z = ray.org.z;
  out.tnear = ray.tmin;
  out.dir_x = ray.dir.x;
  out.dir_y = ray.dir.y;
  out.dir_z = ray.dir.z;
  out.time = 0;
  out.tfar = ray.tmax;
  out.mask = ~0u;
  out.id = 0;
  out.flags = 0;
}

Hit to_hit(const RTCRayHit& rayhit) {
  Hit hit;
  if (rayhit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return hit;
  hit.t = rayhit.ray.tfar;
  hit.prim = rayhit.hit.primID;
  hit.u = rayhit.hit.u;
  hit.v = rayhit.hit.v;
  return hit;
}

class EmbreeAccel final : public EmbreeScene {
 public:
  EmbreeAccel(std::span<const Triangle> triangles, const BuildConfig& config) {
    const Quality quality = parse_quality(config.builder);
    const int threads = config.threads > 0 ? config.threads : hardware_threads();
    const std::string device_config = "threads=" + std::to_string(threads);
    device_.reset(rtcNewDevice(device_config.c_str()));
    if (!device_)
      throw Error("embree", std::string("cannot create a device (") +
                                error_name(rtcGetDeviceError(nullptr)) + ")");
    rtcSetDeviceErrorFunction(device_.get(), on_error, &state_);
    rtcSetDeviceMemoryMonitorFunction(device_.get(), on_memory, &state_);

    Timer timer;
    scene_.reset(rtcNewScene(device_.get()));
    check("creating the scene");
    rtcSetSceneBuildQuality(scene_.get(), quality.scene);
    rtcSetSceneFlags(scene_.get(),
                     (quality.dynamic ? RTC_SCENE_FLAG_DYNAMIC : RTC_SCENE_FLAG_NONE) |
                         (quality.robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE));
    geometry_.reset(rtcNewGeometry(device_.get(), RTC_GEOMETRY_TYPE_TRIANGLE));
    check("creating the geometry");
    RTCGeometry geometry = geometry_.get();
    rtcSetGeometryBuildQuality(geometry, quality.geometry);
    // A triangle soup: three vertices per triangle, indices 3i, 3i+1, 3i+2. Embree pads the
    // buffers it allocates itself, as its 16-byte vertex loads need.
    const std::size_t n = triangles.size();
    if (3 * n > 0xffffffffu) throw Error("embree", "too many triangles for 32-bit vertex indices");
    vertices_ = static_cast<float*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), 3 * n));
    auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), n));
    check("creating the triangle buffers");
    prims_ = n;
    write_vertices(triangles);
    for (std::size_t i = 0; i < 3 * n; ++i) indices[i] = static_cast<unsigned>(i);
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(scene_.get(), geometry);  // the scene keeps its own reference
    rtcCommitScene(scene_.get());
    check("building the scene");

    stats_.accel = "embree";
    stats_.builder = config.builder.empty() ? "medium" : config.builder;
    stats_.prims = stats_.prim_refs = n;
    stats_.build_ms = timer.ms();
    stats_.bytes = static_cast<std::size_t>(std::max<std::int64_t>(0, state_.bytes.load()));
    // Embree does not expose its tree: node counts and SAH cost stay unknown (0 / nullopt).
  }

  double update(std::span<const Triangle> triangles) override {
    if (triangles.size() != prims_)
      throw Error("--accel embree", "a frame has " + std::to_string(triangles.size()) +
                                        " triangles, the scene " + std::to_string(prims_) +
                                        ": a deforming mesh keeps its triangle count");
    check_triangles(triangles, "--accel embree");
    const Timer timer;
    write_vertices(triangles);
    rtcUpdateGeometryBuffer(geometry_.get(), RTC_BUFFER_TYPE_VERTEX, 0);
    rtcCommitGeometry(geometry_.get());
    rtcCommitScene(scene_.get());
    check("updating the scene");
    stats_.build_ms = timer.ms();
    return stats_.build_ms;
  }

  Hit closest_hit(const Ray& ray) const override {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit rayhit;
    fill_ray(ray, rayhit.ray);
    rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rayhit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(scene_.get(), &context, &rayhit);
    return to_hit(rayhit);
  }

  bool any_hit(const Ray& ray) const override {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRay r;
    fill_ray(ray, r);
    rtcOccluded1(scene_.get(), &context, &r);
    return r.tfar < 0;  // Embree sets tfar to -inf on a hit
  }

  // Batched calls: packets of 8 (rtcIntersect8 / rtcOccluded8), measured on 2 AVX-512 cores
  // (dragon, 1M rays) at ~1.05-1.35x rtcIntersect1; 16-wide packets and incoherent streams
  // were slower. Coherent streams (rtcIntersect1M) were ~1.5x faster still on camera rays, but
  // they pick other primitives at ties (coplanar faces) and other last bits of t than
  // rtcIntersect1 (~0.3% of the rays in sibenik), which the interface does not allow.
  void closest_hits(std::span<const Ray> rays, std::span<Hit> hits) const override {
    parallel_chunks(rays.size(), kChunk, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; i += kPacket)
        intersect_packet(rays.subspan(i, std::min(kPacket, end - i)), hits.subspan(i));
    });
  }

  void any_hits(std::span<const Ray> rays, std::span<std::uint8_t> result) const override {
    parallel_chunks(rays.size(), kChunk, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; i += kPacket)
        occluded_packet(rays.subspan(i, std::min(kPacket, end - i)), result.subspan(i));
    });
  }

  const AccelStats& stats() const override { return stats_; }

 private:
  static constexpr std::size_t kChunk = 256;  // rays per parallel task
  static constexpr std::size_t kPacket = 8;

  // Fills packet lanes [0, rays.size()) and marks the rest invalid (a copy of the last ray).
  template <typename Packet>
  static void fill_packet(std::span<const Ray> rays, int* valid, Packet& p) {
    for (std::size_t j = 0; j < kPacket; ++j) {
      valid[j] = j < rays.size() ? -1 : 0;
      const Ray& ray = rays[std::min(j, rays.size() - 1)];
      p.org_x[j] = ray.org.x;
      p.org_y[j] = ray.org.y;
      p.org_z[j] = ray.org.z;
      p.tnear[j] = ray.tmin;
      p.dir_x[j] = ray.dir.x;
      p.dir_y[j] = ray.dir.y;
      p.dir_z[j] = ray.dir.z;
      p.time[j] = 0;
      p.tfar[j] = ray.tmax;
      p.mask[j] = ~0u;
      p.id[j] = static_cast<unsigned>(j);
      p.flags[j] = 0;
    }
  }

  void intersect_packet(std::span<const Ray> rays, std::span<Hit> hits) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    alignas(32) int valid[kPacket];
    RTCRayHit8 packet;
    fill_packet(rays, valid, packet.ray);
    for (std::size_t j = 0; j < kPacket; ++j) {
      packet.hit.geomID[j] = RTC_INVALID_GEOMETRY_ID;
      packet.hit.instID[0][j] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect8(valid, scene_.get(), &context, &packet);
    for (std::size_t j = 0; j < rays.size(); ++j) {
      Hit& hit = hits[j];
      hit = Hit{};
      if (packet.hit.geomID[j] == RTC_INVALID_GEOMETRY_ID) continue;
      hit.t = packet.ray.tfar[j];
      hit.prim = packet.hit.primID[j];
      hit.u = packet.hit.u[j];
      hit.v = packet.hit.v[j];
    }
  }

  void occluded_packet(std::span<const Ray> rays, std::span<std::uint8_t> result) const {
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    alignas(32) int valid[kPacket];
    RTCRay8 packet;
    fill_packet(rays, valid, packet);
    rtcOccluded8(valid, scene_.get(), &context, &packet);
    for (std::size_t j = 0; j < rays.size(); ++j) result[j] = packet.tfar[j] < 0 ? 1 : 0;
  }

  void write_vertices(std::span<const Triangle> triangles) {
    for (std::size_t i = 0; i < triangles.size(); ++i) {
      for (int k = 0; k < 3; ++k) {
        const Vec3 p = triangles[i].vertex(k);
        float* out = vertices_ + 9 * i + 3 * static_cast<std::size_t>(k);
        out[0] = p.x;
        out[1] = p.y;
        out[2] = p.z;
      }
    }
  }

  void check(const char* what) {
    const std::lock_guard lock(state_.mutex);
    if (!state_.error.empty()) throw Error("embree", std::string(what) + ": " + state_.error);
  }

  DeviceState state_;  // first: outlives the device whose callbacks use it
  std::unique_ptr<RTCDeviceTy, decltype(&rtcReleaseDevice)> device_{nullptr, rtcReleaseDevice};
  std::unique_ptr<RTCSceneTy, decltype(&rtcReleaseScene)> scene_{nullptr, rtcReleaseScene};
  std::unique_ptr<RTCGeometryTy, decltype(&rtcReleaseGeometry)> geometry_{nullptr,
                                                                          rtcReleaseGeometry};
  float* vertices_ = nullptr;  // Embree's vertex buffer of geometry_
  std::size_t prims_ = 0;
  AccelStats stats_;
};

}  // namespace

std::unique_ptr<Accel> make_embree(std::span<const Triangle> triangles, const BuildConfig& config) {
  return std::make_unique<EmbreeAccel>(triangles, config);
}

std::unique_ptr<EmbreeScene> make_embree_scene(std::span<const Triangle> triangles,
                                               const BuildConfig& config) {
  check_triangles(triangles, "--accel embree");
  return std::make_unique<EmbreeAccel>(triangles, config);
}

}  // namespace splitray

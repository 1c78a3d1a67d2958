#pragma once
// The one interface every hierarchy answers (DESIGN §2), so that renderers, tests and
// benchmarks swap structures by name: `make_accel("kd", triangles, config)`.
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "splitray/accel/neural/neural_config.hpp"
#include "splitray/core/coordinates.hpp"
#include "splitray/core/ray.hpp"
#include "splitray/core/triangle.hpp"

namespace splitray {

// The SAH constants K_T (a node step) and K_I (a triangle test).
struct SahConstants {
  float traversal, intersection;
};

// The literature's constants: the defaults of every structure but the kd-tree (BIH, BVH,
// brute), and those the shipped neural model (models/sah.bin) was trained with.
inline constexpr SahConstants kSharedSah{15, 20};
inline constexpr float kSharedTraversalCost = kSharedSah.traversal,
                       kSharedIntersectionCost = kSharedSah.intersection;
// The kd-tree's defaults, measured on this implementation (8-byte-node walk, 8-wide SIMD leaf
// test): fitting trace times to the SAH's node steps and triangle tests gave a median K_T of
// 70.8 at K_I = 20 over the 15 benchmark meshes (bench/results/kd_costs.md; reproduce with
// `splitray bench kd-costs --kt 10 15 20 30 45 60 90 120 180`).
inline constexpr SahConstants kKdSah{70, 20};

// Build settings shared by every structure; each reads the fields that apply to it.
struct BuildConfig {
  std::string builder;  // empty = the structure's default builder
  // K_T and K_I of the SAH; unset = the structure's own default (kKdSah, kSharedSah).
  std::optional<float> traversal_cost, intersection_cost;
  float empty_bonus = 0.2f;  // SAH discount for cutting off empty space (Wald & Havran: 0.2)
  int max_depth = 0;         // 0 = automatic (8 + 1.3 log2 N, as in pbrt / Wald & Havran)
  int max_leaf_prims = 1;    // a node with this many or fewer primitives is never split
  int bins = 64;             // binned builders
  int threads = 0;           // 0 = all cores; the built structure never depends on it
  NeuralConfig neural{};     // --builder neural (paper 003)

  // The one resolution of the SAH constants: those given, else the structure's `defaults`.
  SahConstants sah(SahConstants defaults) const {
    return {traversal_cost.value_or(defaults.traversal),
            intersection_cost.value_or(defaults.intersection)};
  }
  // This config with its constants fixed to sah(defaults): what a structure hands to code of
  // another structure it builds with (the BVH's kd top), so that it keeps its own defaults.
  BuildConfig with_sah(SahConstants defaults) const {
    BuildConfig fixed = *this;
    const SahConstants c = sah(defaults);
    fixed.traversal_cost = c.traversal;
    fixed.intersection_cost = c.intersection;
    return fixed;
  }
};

struct AccelStats {
  std::string accel;    // "kd", "brute", ...
  std::string builder;  // the builder actually used
  std::size_t prims = 0;
  double build_ms = 0;
  std::size_t nodes = 0;  // all nodes, leaves included
  std::size_t leaves = 0;
  std::size_t empty_leaves = 0;
  int max_depth = 0;
  double mean_leaf_depth = 0;
  double mean_leaf_prims = 0;  // primitive references per non-empty leaf
  std::size_t prim_refs = 0;   // primitive references in all leaves
  std::size_t bytes = 0;
  std::optional<double> sah_cost;  // from sah_cost.hpp, comparable across structures
  // Its parts: expected node steps and triangle tests of a ray through the root
  // (sah_cost = sah_traversal_cost * steps + sah_intersection_cost * tests).
  std::optional<double> sah_node_steps, sah_triangle_tests;
  float sah_traversal_cost = 0, sah_intersection_cost = 0;  // the K_T and K_I it was computed with
  std::uint64_t cost_evals = 0;        // SAH cost evaluations made while building
  std::optional<double> inference_ms;  // --builder neural: the network's greedy top inference
  std::optional<int> top_depth;        // --builder neural: levels of the inferred top
};

// Every structure answers through these non-virtual calls, which bring rays to the domain of
// coordinates.hpp first (one mechanism for all of them): a ray with a NaN or inf component, a
// zero direction or an origin beyond +-2^40 misses, and a direction whose largest component lies
// outside [2^-2, 2^2] is rescaled by an exact power of two (t is reported for the caller's
// direction). The protected virtuals only ever see rays of that domain.
class Accel {
 public:
  virtual ~Accel() = default;

  // Closest hit with ray.tmin <= t <= ray.tmax; ties go to the smaller primitive id.
  Hit intersect(const Ray& ray) const;
  // Any hit with ray.tmin <= t <= ray.tmax.
  bool occluded(const Ray& ray) const;

  // Batched versions over all cores; results are identical to the single-ray calls.
  void intersect(std::span<const Ray> rays, std::span<Hit> hits) const;
  void occluded(std::span<const Ray> rays, std::span<std::uint8_t> occluded) const;
  // The batched calls made of one single-ray call per ray (what `trace --single` measures).
  void intersect_each(std::span<const Ray> rays, std::span<Hit> hits) const;
  void occluded_each(std::span<const Ray> rays, std::span<std::uint8_t> occluded) const;

  virtual const AccelStats& stats() const = 0;

  // Moves the structure to a deformed mesh with the same triangles (count and order) without
  // rebuilding. Returns false when the structure cannot refit (then rebuild it). Throws Error
  // when a vertex lies beyond the coordinate limit.
  bool refit(std::span<const Triangle> triangles);

 protected:
  // For rays of the domain above only.
  virtual Hit closest_hit(const Ray& ray) const = 0;
  virtual bool any_hit(const Ray& ray) const = 0;
  // Default: the single-ray calls over all cores.
  virtual void closest_hits(std::span<const Ray> rays, std::span<Hit> hits) const;
  virtual void any_hits(std::span<const Ray> rays, std::span<std::uint8_t> occluded) const;
  virtual bool refit_to(std::span<const Triangle> triangles) {
    (void)triangles;
    return false;
  }
};

// Creates a structure by name ("kd", "brute", "embree", ...). Throws Error on an unknown
// name or builder, or an option value outside what the structure takes (build_options.hpp,
// which also lists the options a structure ignores). The structure keeps its own copy of what it
// needs of `triangles`.
std::unique_ptr<Accel> make_accel(const std::string& name, std::span<const Triangle> triangles,
                                  const BuildConfig& config = {});

// Names make_accel accepts, and the builders of each (first = default).
std::vector<std::string> accel_names();
std::vector<std::string> builder_names(const std::string& accel);
// Whether make_accel(accel) also takes builder "neural" (not listed by builder_names).
bool has_neural_builder(const std::string& accel);
// The SAH constants make_accel(accel) builds with when the config leaves them unset.
SahConstants default_sah(const std::string& accel);

}  // namespace splitray

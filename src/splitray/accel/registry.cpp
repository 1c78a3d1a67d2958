#include <functional>
#include <map>

#include "splitray/accel/accel.hpp"
#include "splitray/accel/bih/bih.hpp"
#include "splitray/accel/bih/bih_accel.hpp"
#include "splitray/accel/brute/brute.hpp"
#include "splitray/accel/build_options.hpp"
#include "splitray/accel/bvh/bvh.hpp"
#include "splitray/accel/bvh/bvh_accel.hpp"
#include "splitray/accel/embree/embree_accel.hpp"
#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/accel/neural/neural_accel.hpp"
#include "splitray/core/coordinates.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

struct Entry {
  std::vector<std::string> builders;  // first = default
  std::function<std::unique_ptr<Accel>(std::span<const Triangle>, const BuildConfig&)> make;
  // Takes --builder neural too (paper 003). Kept out of `builders`, which benchmarks and
  // tests iterate: the neural builder needs a model file that may be absent.
  bool neural = false;
  // The SAH constants it builds with when the config leaves them unset (each structure
  // resolves them with BuildConfig::sah; this is what it resolves to, for help and reports).
  SahConstants sah = kSharedSah;
};

using MakeFn = std::unique_ptr<Accel> (*)(std::span<const Triangle>, const BuildConfig&);
template <MakeFn kMake, MakeFn kMakeNeural>
std::unique_ptr<Accel> make_or_neural(std::span<const Triangle> triangles,
                                      const BuildConfig& config) {
  return config.builder == "neural" ? kMakeNeural(triangles, config) : kMake(triangles, config);
}

const std::map<std::string, Entry>& registry() {
  static const std::map<std::string, Entry> entries = {
      {"brute", {{"none"}, make_brute}},
      {"kd", {kd_builder_names(), make_or_neural<make_kd, make_neural_kd>, true, kKdSah}},
      {"embree", {{"medium", "low", "high", "refit", "medium-robust", "low-robust"}, make_embree}},
      {"bih", {bih_builder_names(), make_bih}},
      {"bvh", {Bvh::builder_names(), make_or_neural<make_bvh, make_neural_bvh>, true}},
  };
  return entries;
}

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

}  // namespace

std::vector<std::string> accel_names() {
  std::vector<std::string> names;
  for (const auto& [name, entry] : registry()) names.push_back(name);
  return names;
}

std::vector<std::string> builder_names(const std::string& accel) {
  const auto it = registry().find(accel);
  if (it == registry().end())
    throw Error("--accel",
                "unknown structure '" + accel + "' (known: " + join(accel_names()) + ")");
  return it->second.builders;
}

bool has_neural_builder(const std::string& accel) {
  const auto it = registry().find(accel);
  return it != registry().end() && it->second.neural;
}

SahConstants default_sah(const std::string& accel) {
  builder_names(accel);  // throws on an unknown name
  return registry().at(accel).sah;
}

std::unique_ptr<Accel> make_accel(const std::string& name, std::span<const Triangle> triangles,
                                  const BuildConfig& config) {
  const std::vector<std::string> builders = builder_names(name);
  BuildConfig resolved = config;
  if (resolved.builder.empty()) resolved.builder = builders.front();
  bool known = resolved.builder == "neural" && has_neural_builder(name);
  for (const auto& b : builders) known = known || b == resolved.builder;
  if (!known)
    throw Error("--builder", "'" + resolved.builder + "' is not a builder of --accel " + name +
                                 " (known: " + join(builders) +
                                 (has_neural_builder(name) ? ", neural" : "") + ")");
  check_build_options(name, resolved);
  if (triangles.empty()) throw Error("build", "no triangles to build on");
  check_triangles(triangles, "build");  // NaN, inf or beyond +-2^40: no structure is exact there
  ThreadLimit limit(resolved.threads);
  return registry().at(name).make(triangles, resolved);
}

}  // namespace splitray

#include <functional>
#include <map>

#include "splitray/accel/accel.hpp"
#include "splitray/accel/bih/bih_accel.hpp"
#include "splitray/accel/brute/brute.hpp"
#include "splitray/accel/bvh/bvh_accel.hpp"
#include "splitray/accel/embree/embree_accel.hpp"
#include "splitray/accel/kd/kd_accel.hpp"
#include "splitray/core/errors.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

struct Entry {
  std::vector<std::string> builders;  // first = default
  std::function<std::unique_ptr<Accel>(std::span<const Triangle>, const BuildConfig&)> make;
};

const std::map<std::string, Entry>& registry() {
  static const std::map<std::string, Entry> entries = {
      {"brute", {{"none"}, make_brute}},
      {"kd", {kd_builder_names(), make_kd}},
      {"embree", {{"medium", "low", "high"}, make_embree}},
      {"bih", {{"global", "median", "middle", "sah"}, make_bih}},
      {"bvh", {{"binned", "sbvh"}, make_bvh}},
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
  if (it == registry().end()) throw Error("--accel", "unknown structure '" + accel + "' (known: " + join(accel_names()) + ")");
  return it->second.builders;
}

std::unique_ptr<Accel> make_accel(const std::string& name, std::span<const Triangle> triangles,
                                  const BuildConfig& config) {
  const std::vector<std::string> builders = builder_names(name);
  BuildConfig resolved = config;
  if (resolved.builder.empty()) resolved.builder = builders.front();
  bool known = false;
  for (const auto& b : builders) known = known || b == resolved.builder;
  if (!known)
    throw Error("--builder", "'" + resolved.builder + "' is not a builder of --accel " + name +
                                 " (known: " + join(builders) + ")");
  if (triangles.empty()) throw Error("build", "no triangles to build on");
  ThreadLimit limit(resolved.threads);
  return registry().at(name).make(triangles, resolved);
}

}  // namespace splitray

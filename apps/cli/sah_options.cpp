#include "sah_options.hpp"

#include <fmt/core.h>

#include "splitray/accel/accel.hpp"

namespace splitray::cli {

void add_sah_options(CLI::App& command, std::optional<float>& traversal_cost,
                     std::optional<float>& intersection_cost, const std::string& group) {
  CLI::Option* kt =
      command
          .add_option_function<float>(
              "--kt", [&traversal_cost](const float& v) { traversal_cost = v; },
              fmt::format("SAH cost of traversing a node (K_T; default: kd {}, measured by "
                          "`splitray bench kd-costs`; bih, bvh and the neural model {})",
                          kKdSah.traversal, kSharedSah.traversal))
          ->check(CLI::PositiveNumber);
  CLI::Option* ki =
      command
          .add_option_function<float>(
              "--ki", [&intersection_cost](const float& v) { intersection_cost = v; },
              fmt::format("SAH cost of intersecting a triangle (K_I; default: kd {}, others {})",
                          kKdSah.intersection, kSharedSah.intersection))
          ->check(CLI::PositiveNumber);
  if (!group.empty()) {
    kt->group(group);
    ki->group(group);
  }
}

}  // namespace splitray::cli

#pragma once
// Which options of BuildConfig each structure reads, and the values it takes, by their
// command-line names. make_accel checks every config against this (one rule for all
// structures: a value outside the range that the structure takes is an Error naming the
// option, never a silent clamp) and unused_options() lists the options a structure ignores,
// as pbrt-v4's ReportUnused does, so that a user learns that e.g. `--bins` does nothing for
// `--accel embree`.
#include <string>
#include <vector>

#include "splitray/accel/accel.hpp"

namespace splitray {

// Throws Error naming the option when a value the structure reads is outside its range
// (`accel` and config.builder must be known; an empty builder is the default one).
void check_build_options(const std::string& accel, const BuildConfig& config);

// The options (by command-line name, e.g. "--bins") that `config` sets to other than their
// defaults and that structure `accel` with config.builder does not read.
std::vector<std::string> unused_options(const std::string& accel, const BuildConfig& config);

}  // namespace splitray

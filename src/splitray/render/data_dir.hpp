#pragma once
// Where the vendored data (data/ of the source tree) is found at run time.
#include <string>

namespace splitray {

// The path of `relative` (e.g. "dragon_100k/dragon.obj.gz") under the first data folder that
// has it: $SPLITRAY_DATA_DIR, the source tree's data/ (compiled in), then share/splitray/data
// under the install prefix (compiled in, and relative to the running executable).
// Throws Error naming every place looked at when none has it.
std::string find_data_file(const std::string& relative);

}  // namespace splitray

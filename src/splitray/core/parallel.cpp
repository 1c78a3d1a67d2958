#include "splitray/core/parallel.hpp"

#include <tbb/info.h>

namespace splitray {

int hardware_threads() { return tbb::info::default_concurrency(); }

}  // namespace splitray

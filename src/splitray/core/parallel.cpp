#include "splitray/core/parallel.hpp"

#include <tbb/info.h>
#include <tbb/task_arena.h>

#include <algorithm>

namespace splitray {

int hardware_threads() { return tbb::info::default_concurrency(); }

#if defined(SPLITRAY_TSAN)
int detail::worker_limit() {
  const auto limit =
      tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
  return std::max(1, std::min(static_cast<int>(limit), tbb::this_task_arena::max_concurrency()));
}
#endif

}  // namespace splitray

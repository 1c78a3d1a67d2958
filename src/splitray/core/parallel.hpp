#pragma once
// Parallel loops over TBB, and a scope that limits the worker count.
// Work is split into fixed chunks whose results never depend on which thread ran them.
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <cstddef>
#include <memory>

namespace splitray {

// While alive, TBB uses at most `threads` threads (0 = all cores).
class ThreadLimit {
 public:
  explicit ThreadLimit(int threads) {
    if (threads > 0)
      control_ = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                       static_cast<std::size_t>(threads));
  }

 private:
  std::unique_ptr<tbb::global_control> control_;
};

int hardware_threads();

// Calls body(begin, end) on disjoint chunks of [0, n) of about `grain` items, in parallel.
template <typename Body>
void parallel_chunks(std::size_t n, std::size_t grain, const Body& body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain == 0 ? 1 : grain),
                    [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
}

}  // namespace splitray

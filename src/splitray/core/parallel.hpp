#pragma once
// Every parallel construct of the library: loops over chunks or indices, fork-join of a few
// functions, and reductions over fixed chunks, all over TBB, and a scope that limits the worker
// count. Work is split so that results never depend on which thread ran what.
//
// ThreadSanitizer cannot see how TBB orders work (its scheduler synchronises with atomics inside
// Debian's uninstrumented libtbb.so), so in TSan builds each construct states its real ordering
// itself: everything before it happens before every task it runs, and every task happens
// before everything after it. Tasks are not ordered among themselves, so races between them
// are still found.
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <cstddef>
#include <memory>
#include <vector>

#if defined(__SANITIZE_THREAD__)
#define SPLITRAY_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define SPLITRAY_TSAN 1
#endif
#endif
#if defined(SPLITRAY_TSAN)
extern "C" void __tsan_acquire(void* address);
extern "C" void __tsan_release(void* address);
#endif

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

namespace detail {

// The fork and join edges of one parallel construct, for ThreadSanitizer (nothing otherwise).
class ForkJoin {
 public:
#if defined(SPLITRAY_TSAN)
  ForkJoin() { __tsan_release(&fork_); }
  void joined() { __tsan_acquire(&join_); }
  // Alive while one task runs: it sees what preceded the construct and publishes its work.
  class Task {
   public:
    explicit Task(ForkJoin& sync) : sync_(sync) { __tsan_acquire(&sync_.fork_); }
    ~Task() { __tsan_release(&sync_.join_); }
    Task(const Task&) = delete;
    Task& operator=(const Task&) = delete;

   private:
    ForkJoin& sync_;
  };

 private:
  char fork_ = 0, join_ = 0;
#else
  void joined() {}
  struct Task {
    explicit Task(ForkJoin&) {}
  };
#endif
};

// Joins on every exit, also when a task throws.
class JoinGuard {
 public:
  explicit JoinGuard(ForkJoin& sync) : sync_(sync) {}
  ~JoinGuard() { sync_.joined(); }
  JoinGuard(const JoinGuard&) = delete;
  JoinGuard& operator=(const JoinGuard&) = delete;

 private:
  ForkJoin& sync_;
};

}  // namespace detail

// Calls body(begin, end) on disjoint chunks of [0, n) of about `grain` items, in parallel.
template <typename Body>
void parallel_chunks(std::size_t n, std::size_t grain, const Body& body) {
  detail::ForkJoin sync;
  const detail::JoinGuard join(sync);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain == 0 ? 1 : grain),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      const detail::ForkJoin::Task task(sync);
                      body(r.begin(), r.end());
                    });
}

// Calls body(i) for every i in [0, n), each a task of its own (for few, large items).
template <typename Body>
void parallel_for_each_index(std::size_t n, const Body& body) {
  detail::ForkJoin sync;
  const detail::JoinGuard join(sync);
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
    const detail::ForkJoin::Task task(sync);
    body(i);
  });
}

// Runs the functions in parallel and returns when all have (an exception of one is rethrown
// after all have finished).
template <typename... Functions>
void parallel_invoke(const Functions&... functions) {
  static_assert(sizeof...(Functions) >= 2);
  detail::ForkJoin sync;
  const detail::JoinGuard join(sync);
  tbb::parallel_invoke([&] {
    const detail::ForkJoin::Task task(sync);
    functions();
  }...);
}

// Reduces [0, n) over fixed chunks: chunk(begin, end, partial) adds the items to one of
// `identity`'s copies, combine(total, partial) merges them in chunk order. The chunks do not
// depend on the thread count (at most 64 of at least `grain` items), so neither does the result.
template <typename T, typename Chunk, typename Combine>
T parallel_reduce(std::size_t n, std::size_t grain, const T& identity, const Chunk& chunk,
                  const Combine& combine) {
  const std::size_t chunks = std::clamp<std::size_t>(n / std::max<std::size_t>(grain, 1), 1, 64);
  std::vector<T> partials(chunks, identity);
  parallel_for_each_index(
      chunks, [&](std::size_t c) { chunk(n * c / chunks, n * (c + 1) / chunks, partials[c]); });
  for (std::size_t c = 1; c < chunks; ++c) combine(partials[0], partials[c]);
  return std::move(partials[0]);
}

}  // namespace splitray

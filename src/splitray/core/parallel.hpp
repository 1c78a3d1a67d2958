#pragma once
// Every parallel construct of the library: loops over chunks or indices, fork-join of a few
// functions, reductions over fixed chunks and per-thread scratch (ThreadLocal), all over TBB,
// and a scope that limits the worker count. Work is split so that results never depend on which
// thread ran what.
//
// ThreadSanitizer cannot see how TBB orders work (its scheduler synchronises with atomics inside
// Debian's uninstrumented libtbb.so), so in TSan builds the same constructs run on plain threads
// whose start and join it does see: the caller runs its share, helpers are started for the
// rest (at most kTsanHelpers alive in the whole process, else the work runs inline) and joined
// before the construct returns. Chunks are handed out by a relaxed counter, which orders
// nothing, so races between tasks are still found; the worker limits below are honoured.
#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include <algorithm>
#include <cstddef>
#include <functional>
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
#include <atomic>
#include <deque>
#include <exception>
#include <map>
#include <mutex>
#include <thread>
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

#if defined(SPLITRAY_TSAN)
namespace detail {

inline constexpr int kTsanHelpers = 8;

// Every helper locks this once its work is done and ThreadLocal::local() locks it too: a
// helper's thread id (and with it its ThreadLocal slot) may be reused by a thread that an
// unrelated construct starts, and TSan must see the first thread's writes ordered before.
inline std::mutex& handoff_mutex() {
  static std::mutex mutex;
  return mutex;
}

// The workers a construct may use here: the smallest of the ThreadLimit in force and the
// enclosing task_arena's concurrency.
int worker_limit();

// Runs work(worker) for worker 0 (the caller) .. count - 1 (helper threads, as many as the
// process-wide budget allows; the rest of the work falls to whoever runs) and joins them; the
// first exception is rethrown after all have finished.
template <typename Work>
void run_workers(int count, const Work& work) {
  static std::atomic<int> helpers_alive{0};
  int helpers = 0;
  while (helpers + 1 < count &&
         helpers_alive.fetch_add(1, std::memory_order_relaxed) < kTsanHelpers)
    ++helpers;
  if (helpers + 1 < count) helpers_alive.fetch_sub(1, std::memory_order_relaxed);
  std::exception_ptr error;
  std::mutex error_mutex;
  const auto guarded = [&](int worker) {
    try {
      work(worker);
    } catch (...) {
      const std::lock_guard lock(error_mutex);
      if (!error) error = std::current_exception();
    }
    const std::lock_guard handoff(handoff_mutex());
  };
  std::vector<std::thread> threads;
  for (int h = 1; h <= helpers; ++h) threads.emplace_back(guarded, h);
  guarded(0);
  for (std::thread& t : threads) t.join();
  helpers_alive.fetch_sub(helpers, std::memory_order_relaxed);
  if (error) std::rethrow_exception(error);
}

// Calls item(i) for every i in [0, items) on up to worker_limit() workers.
template <typename Item>
void run_items(std::size_t items, const Item& item) {
  if (items == 0) return;
  std::atomic<std::size_t> next{0};
  const int workers = static_cast<int>(std::min<std::size_t>(items, worker_limit()));
  run_workers(workers, [&](int) {
    for (std::size_t i; (i = next.fetch_add(1, std::memory_order_relaxed)) < items;) item(i);
  });
}

}  // namespace detail

template <typename Body>
void parallel_chunks(std::size_t n, std::size_t grain, const Body& body) {
  const std::size_t g = std::max<std::size_t>(grain, 1);
  detail::run_items((n + g - 1) / g, [&](std::size_t c) { body(c * g, std::min(n, (c + 1) * g)); });
}

template <typename Body>
void parallel_for_each_index(std::size_t n, const Body& body) {
  detail::run_items(n, body);
}

template <typename... Functions>
void parallel_invoke(const Functions&... functions) {
  static_assert(sizeof...(Functions) >= 2);
  const std::vector<std::function<void()>> calls{std::function<void()>(functions)...};
  detail::run_items(calls.size(), [&](std::size_t i) { calls[i](); });
}

// One T per thread that asks for it (scratch arenas, counters); iterate only when no construct
// runs. TBB's enumerable_thread_specific synchronises its table with atomics TSan cannot
// pair, so here it is a locked map from thread to a T of stable address (a thread id, and its
// slot, may pass to a later thread: see detail::handoff_mutex).
template <typename T>
class ThreadLocal {
 public:
  T& local() {
    const std::lock_guard lock(detail::handoff_mutex());
    T*& slot = slots_[std::this_thread::get_id()];
    if (!slot) slot = &values_.emplace_back();
    return *slot;
  }
  auto begin() { return values_.begin(); }
  auto end() { return values_.end(); }
  auto begin() const { return values_.begin(); }
  auto end() const { return values_.end(); }

 private:
  std::map<std::thread::id, T*> slots_;
  std::deque<T> values_;
};

#else

// One T per thread that asks for it (scratch arenas, counters); iterate only when no construct
// runs.
template <typename T>
using ThreadLocal = tbb::enumerable_thread_specific<T>;

// Calls body(begin, end) on disjoint chunks of [0, n) of about `grain` items, in parallel.
template <typename Body>
void parallel_chunks(std::size_t n, std::size_t grain, const Body& body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain == 0 ? 1 : grain),
                    [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
}

// Calls body(i) for every i in [0, n), each a task of its own (for few, large items).
template <typename Body>
void parallel_for_each_index(std::size_t n, const Body& body) {
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) { body(i); });
}

// Runs the functions in parallel and returns when all have (an exception of one is rethrown
// after all have finished).
template <typename... Functions>
void parallel_invoke(const Functions&... functions) {
  static_assert(sizeof...(Functions) >= 2);
  tbb::parallel_invoke(functions...);
}

#endif

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

// The memory behind HugePageAllocator: fresh mmap ranges trimmed to 2 MiB alignment, hinted for
// transparent huge pages and faulted in by the allocating thread; freed ranges kept for reuse.
//
// Why faulted in here: left to the parallel loop that fills an array, the first faults of two
// threads on the same fresh huge page kept both busy 3x as long, at random (the collapse's fill
// of the dragon: 1.4 or 6.5 ms on 2 threads).
// Why kept: a range given back to the system is cleared again at its next first touch, and on
// VMs that report free memory to the host (virtio-balloon free page reporting) the host backs it
// anew as well. A hierarchy rebuilt every frame (animate) or built again (bench) asks for ranges
// of the same sizes, so up to kKeepBytes of freed ranges wait for the next take() of a size they
// fit (at most a quarter larger), oldest given back to the system first.
#include "splitray/core/huge_page_allocator.hpp"

#if defined(__linux__) && defined(MADV_HUGEPAGE)
#include <algorithm>
#include <cstdint>
#include <map>
#include <mutex>
#include <vector>

namespace splitray::huge_pages {

namespace {

constexpr std::size_t kSmallPage = std::size_t{1} << 12;
constexpr std::size_t kKeepBytes = std::size_t{256} << 20;

std::size_t round_up(std::size_t bytes) { return (bytes + kHugePage - 1) & ~(kHugePage - 1); }

struct Ranges {
  std::mutex mutex;
  std::map<void*, std::size_t> sizes;                // every range handed out or kept
  std::vector<std::pair<void*, std::size_t>> freed;  // kept ranges, oldest first
  std::size_t freed_bytes = 0;
};

// Never destroyed: arrays of static objects may be given back during static destruction.
Ranges& ranges() {
  static Ranges* const instance = new Ranges;  // NOLINT(cppcoreguidelines-owning-memory)
  return *instance;
}

void* map_fresh(std::size_t size) {
  void* raw =
      mmap(nullptr, size + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) throw std::bad_alloc();
  char* const start = static_cast<char*>(raw);
  const std::size_t misalign = reinterpret_cast<std::uintptr_t>(raw) % kHugePage;
  const std::size_t head = misalign == 0 ? 0 : kHugePage - misalign;
  char* const aligned = start + head;
  if (head > 0) munmap(start, head);
  if (kHugePage > head) munmap(aligned + size, kHugePage - head);  // the tail
  madvise(aligned, size, MADV_HUGEPAGE);                           // only a hint
  for (std::size_t offset = 0; offset < size; offset += kSmallPage)
    static_cast<volatile char*>(static_cast<void*>(aligned))[offset] = 0;
  return aligned;
}

}  // namespace

void* take(std::size_t bytes) {
  const std::size_t size = round_up(bytes);
  Ranges& r = ranges();
  {
    const std::lock_guard lock(r.mutex);
    auto best = r.freed.end();
    for (auto it = r.freed.begin(); it != r.freed.end(); ++it)
      if (it->second >= size && it->second <= size + size / 4 &&
          (best == r.freed.end() || it->second < best->second))
        best = it;
    if (best != r.freed.end()) {
      void* const p = best->first;
      r.freed_bytes -= best->second;
      r.freed.erase(best);
      return p;
    }
  }
  void* const p = map_fresh(size);
  const std::lock_guard lock(r.mutex);
  r.sizes[p] = size;
  return p;
}

void give(void* p) noexcept {
  Ranges& r = ranges();
  const std::lock_guard lock(r.mutex);
  const auto it = r.sizes.find(p);
  if (it == r.sizes.end()) return;  // not ours: cannot happen through HugePageAllocator
  r.freed.emplace_back(p, it->second);
  r.freed_bytes += it->second;
  while (r.freed_bytes > kKeepBytes) {
    const auto [oldest, size] = r.freed.front();
    r.freed.erase(r.freed.begin());
    r.freed_bytes -= size;
    r.sizes.erase(oldest);
    munmap(oldest, size);
  }
}

}  // namespace splitray::huge_pages

#endif

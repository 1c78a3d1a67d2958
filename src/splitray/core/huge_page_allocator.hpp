#pragma once
// An allocator for the large arrays that rays walk at random (the nodes and triangle blocks of
// a hierarchy): on Linux, arrays of 1 MiB or more get fresh 2 MiB-aligned pages with the hint
// for transparent huge pages, so that a ray's scattered loads hit the TLB instead of walking
// page tables. Smaller arrays, and other systems, get ordinary aligned memory.
#include <cstddef>
#include <cstdint>
#include <new>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace splitray {

template <class T>
struct HugePageAllocator {
  using value_type = T;
  static constexpr std::size_t kHugePage = std::size_t{1} << 21;
  static constexpr std::size_t kSmallPage = std::size_t{1} << 12;
  static constexpr std::size_t kAlign = alignof(T) > 64 ? alignof(T) : 64;
  static constexpr std::size_t kMinBytes = kHugePage / 2;  // smaller arrays: ordinary memory

  HugePageAllocator() = default;
  template <class U>
  explicit HugePageAllocator(const HugePageAllocator<U>&) {}

  T* allocate(std::size_t n) {
    const std::size_t bytes = n * sizeof(T);
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    if (bytes >= kMinBytes) {
      // Fresh pages from mmap (recycled heap memory would already be backed by small pages),
      // trimmed to a 2 MiB-aligned range.
      const std::size_t rounded = round_up(bytes);
      void* raw = mmap(nullptr, rounded + kHugePage, PROT_READ | PROT_WRITE,
                       MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
      if (raw == MAP_FAILED) throw std::bad_alloc();
      char* const start = static_cast<char*>(raw);
      const std::size_t misalign = reinterpret_cast<std::uintptr_t>(raw) % kHugePage;
      const std::size_t head = misalign == 0 ? 0 : kHugePage - misalign;
      char* const aligned = start + head;
      if (head > 0) munmap(start, head);
      if (kHugePage > head) munmap(aligned + rounded, kHugePage - head);  // the tail
      madvise(aligned, rounded, MADV_HUGEPAGE);                           // only a hint
      // The pages are faulted in here, by one thread. Left to the parallel loop that fills the
      // array, the first faults of two threads on the same fresh huge page kept both busy 3x
      // as long, at random (the collapse's fill of the dragon: 1.4 or 6.5 ms on 2 threads).
      for (std::size_t offset = 0; offset < rounded; offset += kSmallPage)
        static_cast<volatile char*>(aligned)[offset] = 0;
      return reinterpret_cast<T*>(aligned);
    }
#endif
    return static_cast<T*>(::operator new (bytes, std::align_val_t{kAlign}));
  }
  void deallocate(T* p, std::size_t n) noexcept {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    if (n * sizeof(T) >= kMinBytes) {
      munmap(p, round_up(n * sizeof(T)));
      return;
    }
#endif
    ::operator delete (p, std::align_val_t{kAlign});
  }
  static std::size_t round_up(std::size_t bytes) {
    return (bytes + kHugePage - 1) & ~(kHugePage - 1);
  }
  friend bool operator==(const HugePageAllocator&, const HugePageAllocator&) { return true; }
};

template <class T>
using HugePageVector = std::vector<T, HugePageAllocator<T>>;

}  // namespace splitray

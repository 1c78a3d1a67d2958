#pragma once
// An allocator for the large arrays that rays walk at random (the nodes and triangle blocks of
// a hierarchy): on Linux, arrays of 1 MiB or more get 2 MiB-aligned pages with the hint for
// transparent huge pages, so that a ray's scattered loads hit the TLB instead of walking page
// tables. Smaller arrays, and other systems, get ordinary aligned memory.
#include <cstddef>
#include <new>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace splitray {

#if defined(__linux__) && defined(MADV_HUGEPAGE)
namespace huge_pages {

inline constexpr std::size_t kHugePage = std::size_t{1} << 21;
inline constexpr std::size_t kMinBytes = kHugePage / 2;  // smaller arrays: ordinary memory

// At least `bytes` of 2 MiB-aligned memory, hinted for huge pages and already faulted in (see
// huge_page_allocator.cpp); throws std::bad_alloc when the system has none.
void* take(std::size_t bytes);
// Gives back memory from take(); it may be kept for a later take() (up to kKeepBytes).
void give(void* p) noexcept;

}  // namespace huge_pages
#endif

template <class T>
struct HugePageAllocator {
  using value_type = T;
  static constexpr std::size_t kAlign = alignof(T) > 64 ? alignof(T) : 64;

  HugePageAllocator() = default;
  template <class U>
  explicit HugePageAllocator(const HugePageAllocator<U>&) {}

  T* allocate(std::size_t n) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    if (n * sizeof(T) >= huge_pages::kMinBytes)
      return static_cast<T*>(huge_pages::take(n * sizeof(T)));
#endif
    return static_cast<T*>(::operator new (n * sizeof(T), std::align_val_t{kAlign}));
  }
  void deallocate(T* p, std::size_t n) noexcept {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
    if (n * sizeof(T) >= huge_pages::kMinBytes) return huge_pages::give(p);
#endif
    ::operator delete (p, std::align_val_t{kAlign});
  }
  friend bool operator==(const HugePageAllocator&, const HugePageAllocator&) { return true; }
};

template <class T>
using HugePageVector = std::vector<T, HugePageAllocator<T>>;

}  // namespace splitray

#pragma once
// Result sets shared by the tree and the brute-force oracle (internal). Each offers a bound
// `worst()` (a cell whose distance² exceeds it cannot contribute) and `offer(d2, index)`.
// Candidates are ordered by (distance², index), so ties go to the smaller index.
#include <algorithm>
#include <bit>
#include <cstdint>
#include <limits>
#include <vector>

namespace splitray::detail {

inline constexpr float kInfinity = std::numeric_limits<float>::infinity();

// k = 1.
struct NearestOne {
  float d2 = kInfinity;
  std::uint32_t index = UINT32_MAX;

  float worst() const { return d2; }
  void offer(float candidate, std::uint32_t i) {
    if (candidate < d2 || (candidate == d2 && i < index)) {
      d2 = candidate;
      index = i;
    }
  }
};

// Small k: a sorted array, nearest first (inserting shifts at most k entries).
struct NearestSorted {
  float* d2;
  std::uint32_t* index;
  int k;
  int count = 0;

  NearestSorted(float* d2_, std::uint32_t* index_, int k_) : d2(d2_), index(index_), k(k_) {}
  float worst() const { return count < k ? kInfinity : d2[k - 1]; }
  void offer(float candidate, std::uint32_t i) {
    if (count == k && !(candidate < d2[k - 1] || (candidate == d2[k - 1] && i < index[k - 1])))
      return;
    int j = count < k ? count++ : k - 1;
    for (; j > 0 && (d2[j - 1] > candidate || (d2[j - 1] == candidate && index[j - 1] > i)); --j) {
      d2[j] = d2[j - 1];
      index[j] = index[j - 1];
    }
    d2[j] = candidate;
    index[j] = i;
  }
};

// Large k: a bounded max-heap on (distance², index); sorted at the end.
struct NearestHeap {
  struct Entry {
    float d2;
    std::uint32_t index;
    bool operator<(const Entry& o) const { return d2 < o.d2 || (d2 == o.d2 && index < o.index); }
  };
  std::vector<Entry> heap;
  std::size_t k;

  explicit NearestHeap(int k_) : k(static_cast<std::size_t>(k_)) { heap.reserve(k); }
  float worst() const { return heap.size() < k ? kInfinity : heap.front().d2; }
  void offer(float candidate, std::uint32_t i) {
    const Entry e{candidate, i};
    if (heap.size() < k) {
      heap.push_back(e);
      std::push_heap(heap.begin(), heap.end());
    } else if (e < heap.front()) {
      std::pop_heap(heap.begin(), heap.end());
      heap.back() = e;
      std::push_heap(heap.begin(), heap.end());
    }
  }
  // Writes the entries nearest first.
  void finish(float* d2, std::uint32_t* index) {
    std::sort_heap(heap.begin(), heap.end());
    for (std::size_t j = 0; j < heap.size(); ++j) {
      d2[j] = heap[j].d2;
      index[j] = heap[j].index;
    }
  }
};

inline constexpr int kSortedMaxK = 32;  // above this, the heap wins

// Every point with distance² <= r2, in the order found.
struct WithinRadius {
  // (distance² bits, index) in one integer: distances² are >= +0, whose bits order like
  // unsigned integers, so sorting the keys sorts by (distance², index).
  struct Entry {
    std::uint64_t key;
    Entry(float d2, std::uint32_t index)
        : key((static_cast<std::uint64_t>(std::bit_cast<std::uint32_t>(d2)) << 32) | index) {}
    float d2() const { return std::bit_cast<float>(static_cast<std::uint32_t>(key >> 32)); }
    std::uint32_t index() const { return static_cast<std::uint32_t>(key); }
    bool operator<(const Entry& o) const { return key < o.key; }
  };
  float r2;
  std::vector<Entry>* found;

  float worst() const { return r2; }
  void offer(float candidate, std::uint32_t i) {
    if (candidate <= r2) found->emplace_back(candidate, i);
  }
};

}  // namespace splitray::detail

#pragma once
// A stack-like bump allocator for the per-node arrays of a sequential subtree build: a node's
// children are allocated above it and released together once the subtree is done, so a
// build of hundreds of thousands of nodes makes a handful of heap allocations. Not thread
// safe: one arena per sequential task (the golden and binned builders use it).
#include <algorithm>
#include <cstddef>
#include <memory>
#include <vector>

namespace splitray {

class BumpArena {
 public:
  struct Mark {
    std::size_t block, offset;
  };

  explicit BumpArena(std::size_t block_bytes = std::size_t{256} * 1024)
      : block_bytes_(block_bytes) {}

  Mark mark() const { return {block_, offset_}; }
  void release(Mark m) { block_ = m.block, offset_ = m.offset; }

  // Uninitialised room for `count` objects of a trivial type.
  template <typename T>
  T* allocate(std::size_t count) {
    static_assert(alignof(T) <= 16);
    const std::size_t bytes = (count * sizeof(T) + 15) & ~std::size_t{15};
    if (block_ < blocks_.size() && offset_ + bytes <= blocks_[block_].size) {
      T* p = reinterpret_cast<T*>(blocks_[block_].data.get() + offset_);
      offset_ += bytes;
      return p;
    }
    // The next block (unused beyond the current one), replaced when too small.
    const std::size_t next = block_ < blocks_.size() ? block_ + 1 : blocks_.size();
    if (next == blocks_.size()) blocks_.emplace_back();
    if (blocks_[next].size < bytes) {
      const std::size_t size = std::max(block_bytes_, bytes);
      blocks_[next].data = std::make_unique_for_overwrite<std::byte[]>(size);
      blocks_[next].size = size;
    }
    block_ = next;
    offset_ = bytes;
    return reinterpret_cast<T*>(blocks_[next].data.get());
  }

 private:
  struct Block {
    std::unique_ptr<std::byte[]> data;
    std::size_t size = 0;
  };
  std::vector<Block> blocks_;
  std::size_t block_ = 0, offset_ = 0;
  std::size_t block_bytes_;
};

}  // namespace splitray

// Collapsing a binary BVH into the wide layout (wide_bvh.hpp) and refitting it.
#include <algorithm>
#include <limits>
#include <memory>
#include <optional>

#include "splitray/accel/bvh/wide_bvh.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

void set_slot(WideNode& w, int slot, const Aabb& box) {
  for (int a = 0; a < 3; ++a) {
    w.planes[a][slot] = box.lo[a];
    w.planes[3 + a][slot] = box.hi[a];
  }
}

std::uint32_t blocks_of(const BvhNode& leaf) {
  return (leaf.count() + kBlockWidth - 1) / kBlockWidth;
}

// Subtrees this close to the root are solved as parallel tasks (at most 2^6 of them).
constexpr int kParallelDepth = 6;

// The SAH-optimal collapse of Ylitie, Karras & Laine ("Efficient incoherent ray traversal on
// GPUs through compressed wide BVHs", HPG 2017), keeping every binary leaf: cost(n, i) is the
// least SAH cost of the binary subtree n as a forest of at most i slots, computed bottom-up;
// a wide node then takes the kWideWidth slots its children's best forests give. A wide node's
// test costs about one block test (one SIMD slab test against eight triangle tests), so both
// count 1.
// A subtree of L leaves is never better as a forest of more than L slots, so cost(n, i) for
// i > L repeats cost(n, L) and the left child of a split takes at most its own leaf count:
// the same choices as the full O(width^2) search per node, at a fraction of its work (most
// nodes sit near the leaves).
class CollapsePlan {
 public:
  explicit CollapsePlan(std::span<const BvhNode> nodes)
      : nodes_(nodes),
        cost_(std::make_unique_for_overwrite<float[]>(nodes.size() * kWideWidth)),
        split_(std::make_unique_for_overwrite<std::uint8_t[]>(nodes.size() * kWideWidth)),
        wide_split_(std::make_unique_for_overwrite<std::uint8_t[]>(nodes.size())),
        leaves_(std::make_unique_for_overwrite<std::uint8_t[]>(nodes.size())) {
    solve(0, 0);
  }

  // The slots of the wide node made from interior binary node n.
  int slots(std::uint32_t n, std::uint32_t* out) const {
    int count = 0;
    const std::uint8_t k = wide_split_[n];
    expand(nodes_[n].index, k, out, count);
    expand(nodes_[n].index + 1, kWideWidth - k, out, count);
    return count;
  }

 private:
  static constexpr float kNodeCost = 1, kBlockCost = 1;

  float& cost(std::uint32_t n, int i) { return cost_[n * std::size_t{kWideWidth} + i - 1]; }
  float cost(std::uint32_t n, int i) const { return cost_[n * std::size_t{kWideWidth} + i - 1]; }
  // 0: the subtree is one slot; k > 0: k slots to the left child, the rest to the right.
  std::uint8_t& split(std::uint32_t n, int i) {
    return split_[n * std::size_t{kWideWidth} + i - 1];
  }
  std::uint8_t split(std::uint32_t n, int i) const {
    return split_[n * std::size_t{kWideWidth} + i - 1];
  }
  // Left share k of `slots` slots minimising the children's forests (the first least one;
  // shares beyond the left child's leaves are never less).
  std::pair<float, std::uint8_t> distribute(std::uint32_t n, int slots) const {
    const std::uint32_t l = nodes_[n].index, r = l + 1;
    const int last = std::min<int>(leaves_[l], slots - 1);
    float best = std::numeric_limits<float>::infinity();
    std::uint8_t best_k = 1;
    for (int k = 1; k <= last; ++k) {
      const float c = cost(l, k) + cost(r, slots - k);
      if (c < best) best = c, best_k = static_cast<std::uint8_t>(k);
    }
    return {best, best_k};
  }

  void solve(std::uint32_t n, int depth) {
    const BvhNode& node = nodes_[n];
    const float area = node.box().half_area();
    if (node.leaf()) {
      const float leaf = area * kBlockCost * static_cast<float>(blocks_of(node));
      for (int i = 1; i <= kWideWidth; ++i) cost(n, i) = leaf, split(n, i) = 0;
      leaves_[n] = 1;
      return;
    }
    if (depth < kParallelDepth) {
      parallel_invoke([&] { solve(node.index, depth + 1); },
                      [&] { solve(node.index + 1, depth + 1); });
    } else {
      solve(node.index, depth + 1);
      solve(node.index + 1, depth + 1);
    }
    const int leaves = std::min(kWideWidth, leaves_[node.index] + leaves_[node.index + 1]);
    leaves_[n] = static_cast<std::uint8_t>(leaves);
    const auto [wide, wide_k] = distribute(n, kWideWidth);
    cost(n, 1) = area * kNodeCost + wide;  // n as one wide node
    split(n, 1) = 0;
    wide_split_[n] = wide_k;
    for (int i = 2; i <= kWideWidth; ++i) {
      if (i <= leaves) {
        const auto [forest, k] = distribute(n, i);
        if (forest < cost(n, i - 1)) {
          cost(n, i) = forest, split(n, i) = k;
          continue;
        }
      }
      cost(n, i) = cost(n, i - 1), split(n, i) = split(n, i - 1);
    }
  }

  void expand(std::uint32_t n, int slots, std::uint32_t* out, int& count) const {
    const std::uint8_t k = split(n, slots);
    if (k == 0) {
      out[count++] = n;
      return;
    }
    expand(nodes_[n].index, k, out, count);
    expand(nodes_[n].index + 1, slots - k, out, count);
  }

  std::span<const BvhNode> nodes_;
  std::unique_ptr<float[]> cost_;
  std::unique_ptr<std::uint8_t[]> split_;
  std::unique_ptr<std::uint8_t[]> wide_split_;  // the left child's share of a wide node's slots
  std::unique_ptr<std::uint8_t[]> leaves_;      // leaves of each subtree, at most kWideWidth
};

// The wide tree in depth-first order without its boxes and triangles: each slot's binary node
// (`source`), its wide child or first block and block count. The blocks of the leaves are
// numbered in the same walk, so the parallel fill below writes every array where the
// sequential walk would have.
struct Skeleton {
  std::span<const BvhNode> nodes;
  const CollapsePlan& plan;
  HugePageVector<WideNode>& out;
  std::vector<std::uint32_t>& source;
  std::uint32_t blocks = 0;

  std::uint32_t add(std::uint32_t binary) {
    const auto index = static_cast<std::uint32_t>(out.size());
    out.emplace_back();
    source.resize(source.size() + kWideWidth, kInvalidId);
    std::uint32_t slots[kWideWidth];
    int count = 0;
    if (nodes[binary].leaf())
      slots[count++] = binary;
    else
      count = plan.slots(binary, slots);
    for (int i = 0; i < count; ++i) {
      const BvhNode& n = nodes[slots[i]];
      std::uint32_t child, blocks_here = 0;
      if (n.leaf()) {
        child = blocks;
        blocks_here = blocks_of(n);
        blocks += blocks_here;
      } else {
        child = add(slots[i]);  // may move `out`
      }
      out[index].child[i] = child;
      out[index].count[i] = blocks_here;
      source[index * std::size_t{kWideWidth} + static_cast<std::size_t>(i)] = slots[i];
    }
    return index;
  }
};

// Boxes of a wide node's slots (empty slots get an empty box) and its leaves' blocks.
void fill_node(WideNode& w, const std::uint32_t* source, std::span<const BvhNode> nodes,
               std::span<const std::uint32_t> ids, std::span<const Triangle> triangles,
               std::span<TriangleBlock> blocks) {
  // The leaves' triangles lie anywhere in the input: ask for all of them before the first
  // is needed.
  for (int i = 0; i < kWideWidth; ++i)
    if (source[i] != kInvalidId && w.count[i] > 0) {
      const BvhNode& n = nodes[source[i]];
      for (std::uint32_t r = n.index; r < n.index + n.count(); ++r)
        __builtin_prefetch(&triangles[ids[r]]);
    }
  for (int i = 0; i < kWideWidth; ++i) {
    if (source[i] == kInvalidId) {
      set_slot(w, i, Aabb{});
      continue;
    }
    const BvhNode& n = nodes[source[i]];
    set_slot(w, i, n.box());
    if (w.count[i] == 0) continue;
    const std::uint32_t refs = n.count();
    for (std::uint32_t b = 0; b < w.count[i]; ++b) {
      TriangleBlock& block = blocks[w.child[i] + b];
      for (int lane = 0; lane < kBlockWidth; ++lane) {
        const std::uint32_t r =
            n.index + std::min(b * kBlockWidth + static_cast<std::uint32_t>(lane), refs - 1);
        block.set(lane, triangles[ids[r]], ids[r]);
      }
    }
  }
}

}  // namespace

void TriangleBlock::set(int lane, const Triangle& t, std::uint32_t prim) {
  for (int vertex = 0; vertex < 3; ++vertex)
    for (int a = 0; a < 3; ++a) v[3 * vertex + a][lane] = t.vertex(vertex)[a];
  id[lane] = prim;
}

void WideBvh::collapse(std::span<const BvhNode> nodes, std::span<const std::uint32_t> ids,
                       std::span<const Triangle> triangles) {
  nodes_.clear();
  source_.clear();
  blocks_.clear();
  if (nodes.empty()) return;
  nodes_.reserve(nodes.size() / 4 + 1);
  const CollapsePlan plan(nodes);
  Skeleton skeleton{nodes, plan, nodes_, source_};
  skeleton.add(0);
  blocks_.resize(skeleton.blocks);
  parallel_chunks(nodes_.size(), 64, [&](std::size_t begin, std::size_t end) {
    for (std::size_t w = begin; w < end; ++w)
      fill_node(nodes_[w], &source_[w * kWideWidth], nodes, ids, triangles, blocks_);
  });
}

void WideBvh::refit(std::span<const BvhNode> nodes, std::span<const Triangle> triangles) {
  for (std::size_t w = 0; w < nodes_.size(); ++w)
    for (int i = 0; i < kWideWidth; ++i) {
      const std::uint32_t s = source_[w * kWideWidth + static_cast<std::size_t>(i)];
      if (s != kInvalidId) set_slot(nodes_[w], i, nodes[s].box());
    }
  for (TriangleBlock& b : blocks_)
    for (int lane = 0; lane < kBlockWidth; ++lane) b.set(lane, triangles[b.id[lane]], b.id[lane]);
}

}  // namespace splitray

// Collapsing a binary BVH into the wide layout (wide_bvh.hpp) and refitting it.
#include <algorithm>
#include <limits>
#include <optional>

#include "splitray/accel/bvh/wide_bvh.hpp"

namespace splitray {

namespace {

void set_slot(WideNode& w, int slot, const Aabb& box) {
  for (int a = 0; a < 3; ++a) {
    w.planes[a][slot] = box.lo[a];
    w.planes[3 + a][slot] = box.hi[a];
  }
}

struct Collapse {
  std::span<const BvhNode> nodes;
  std::span<const std::uint32_t> ids;
  std::span<const Triangle> triangles;
  HugePageVector<WideNode>& out;
  std::vector<std::uint32_t>& source;
  HugePageVector<TriangleBlock>& blocks;
};

// Appends the blocks of a binary leaf; returns the first.
std::uint32_t add_blocks(const Collapse& c, const BvhNode& leaf, std::uint32_t& count) {
  const auto first = static_cast<std::uint32_t>(c.blocks.size());
  const std::uint32_t refs = leaf.count();
  count = (refs + kBlockWidth - 1) / kBlockWidth;
  for (std::uint32_t b = 0; b < count; ++b) {
    TriangleBlock block;
    for (int lane = 0; lane < kBlockWidth; ++lane) {
      const std::uint32_t r =
          leaf.index + std::min(b * kBlockWidth + static_cast<std::uint32_t>(lane), refs - 1);
      block.set(lane, c.triangles[c.ids[r]], c.ids[r]);
    }
    c.blocks.push_back(block);
  }
  return first;
}

// The SAH-optimal collapse of Ylitie, Karras & Laine ("Efficient incoherent ray traversal on
// GPUs through compressed wide BVHs", HPG 2017), keeping every binary leaf: cost(n, i) is the
// least SAH cost of the binary subtree n as a forest of at most i slots, computed bottom-up;
// a wide node then takes the kWideWidth slots its children's best forests give. A wide node's
// test costs about one block test (one SIMD slab test against eight triangle tests), so both
// count 1.
class CollapsePlan {
 public:
  explicit CollapsePlan(std::span<const BvhNode> nodes)
      : nodes_(nodes),
        cost_(nodes.size() * kWideWidth),
        split_(nodes.size() * kWideWidth),
        wide_split_(nodes.size()) {
    solve(0);
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
  // Left share k of `slots` slots minimising the children's forests.
  std::pair<float, std::uint8_t> distribute(std::uint32_t n, int slots) const {
    const std::uint32_t l = nodes_[n].index, r = l + 1;
    float best = std::numeric_limits<float>::infinity();
    std::uint8_t best_k = 1;
    for (int k = 1; k < slots; ++k) {
      const float c = cost(l, k) + cost(r, slots - k);
      if (c < best) best = c, best_k = static_cast<std::uint8_t>(k);
    }
    return {best, best_k};
  }

  void solve(std::uint32_t n) {
    const BvhNode& node = nodes_[n];
    const float area = node.box().half_area();
    if (node.leaf()) {
      const std::uint32_t blocks = (node.count() + kBlockWidth - 1) / kBlockWidth;  // rounded up
      const float leaf = area * kBlockCost * static_cast<float>(blocks);
      for (int i = 1; i <= kWideWidth; ++i) cost(n, i) = leaf, split(n, i) = 0;
      return;
    }
    solve(node.index);
    solve(node.index + 1);
    const auto [wide, wide_k] = distribute(n, kWideWidth);
    cost(n, 1) = area * kNodeCost + wide;  // n as one wide node
    split(n, 1) = 0;
    wide_split_[n] = wide_k;
    for (int i = 2; i <= kWideWidth; ++i) {
      const auto [forest, k] = distribute(n, i);
      if (forest < cost(n, i - 1)) {
        cost(n, i) = forest, split(n, i) = k;
      } else {
        cost(n, i) = cost(n, i - 1), split(n, i) = split(n, i - 1);
      }
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
  std::vector<float> cost_;
  std::vector<std::uint8_t> split_;
  std::vector<std::uint8_t> wide_split_;  // the left child's share of a wide node's 8 slots
};

std::uint32_t collapse_node(const Collapse& c, const CollapsePlan& plan, std::uint32_t binary) {
  const std::span<const BvhNode> nodes = c.nodes;
  HugePageVector<WideNode>& out = c.out;
  std::vector<std::uint32_t>& source = c.source;
  const auto index = static_cast<std::uint32_t>(out.size());
  out.emplace_back();
  source.resize(source.size() + kWideWidth, kInvalidId);
  std::uint32_t slots[kWideWidth];
  int count = 0;
  if (nodes[binary].leaf())
    slots[count++] = binary;
  else
    count = plan.slots(binary, slots);
  const Aabb empty;
  for (int i = 0; i < kWideWidth; ++i) {
    WideNode& w = out[index];
    w.child[i] = 0;
    w.count[i] = 0;
    set_slot(w, i, empty);
  }
  for (int i = 0; i < count; ++i) {
    const BvhNode& n = nodes[slots[i]];
    std::uint32_t child, refs = 0;  // a leaf: its blocks
    if (n.leaf())
      child = add_blocks(c, n, refs);
    else
      child = collapse_node(c, plan, slots[i]);  // may move `out`
    WideNode& w = out[index];
    set_slot(w, i, n.box());
    w.child[i] = child;
    w.count[i] = refs;
    source[index * kWideWidth + static_cast<std::uint32_t>(i)] = slots[i];
  }
  return index;
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
  blocks_.reserve(ids.size() / 4 + 1);
  const CollapsePlan plan(nodes);
  collapse_node({nodes, ids, triangles, nodes_, source_, blocks_}, plan, 0);
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

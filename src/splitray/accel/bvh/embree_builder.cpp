// Embree's custom BVH builder (rtcBuildBVH) producing our nodes: Embree decides the splits
// (high quality, with spatial splits done by our triangle splitting), the callbacks
// record a temporary binary tree in Embree's thread-local memory, and that tree is laid out
// as a piece.
#include <embree3/rtcore.h>
#include <embree3/rtcore_builder.h>

#include <algorithm>
#include <new>
#include <vector>

#include "splitray/accel/bvh/bvh_build.hpp"
#include "splitray/accel/triangle_clip.hpp"
#include "splitray/core/errors.hpp"

namespace splitray {

namespace {

struct TmpNode {
  bool leaf;
};
struct TmpInner {
  TmpNode base{false};
  Aabb boxes[2];
  TmpNode* kids[2] = {nullptr, nullptr};
};
struct TmpLeaf {
  TmpNode base{true};
  std::uint32_t count = 0;
  std::uint32_t ids[1];  // `count` of them (allocated beyond the struct)
};

struct Context {
  std::span<const Triangle> triangles;
};

Aabb to_aabb(const RTCBounds& b) {
  return {{b.lower_x, b.lower_y, b.lower_z}, {b.upper_x, b.upper_y, b.upper_z}};
}
Aabb to_aabb(const RTCBuildPrimitive& p) {
  return {{p.lower_x, p.lower_y, p.lower_z}, {p.upper_x, p.upper_y, p.upper_z}};
}
void store(const Aabb& a, RTCBounds* b) {
  b->lower_x = a.lo.x, b->lower_y = a.lo.y, b->lower_z = a.lo.z;
  b->upper_x = a.hi.x, b->upper_y = a.hi.y, b->upper_z = a.hi.z;
  b->align0 = b->align1 = 0;
}

void* create_node(RTCThreadLocalAllocator alloc, unsigned int child_count, void*) {
  if (child_count != 2) return nullptr;
  return new (rtcThreadLocalAlloc(alloc, sizeof(TmpInner), 16)) TmpInner;
}

void set_children(void* node, void** children, unsigned int count, void*) {
  auto* inner = static_cast<TmpInner*>(node);
  for (unsigned int i = 0; i < count && i < 2; ++i)
    inner->kids[i] = static_cast<TmpNode*>(children[i]);
}

void set_bounds(void* node, const RTCBounds** bounds, unsigned int count, void*) {
  auto* inner = static_cast<TmpInner*>(node);
  for (unsigned int i = 0; i < count && i < 2; ++i) inner->boxes[i] = to_aabb(*bounds[i]);
}

void* create_leaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* prims, size_t count,
                  void*) {
  void* memory = rtcThreadLocalAlloc(alloc, sizeof(TmpLeaf) + count * sizeof(std::uint32_t), 16);
  auto* leaf = new (memory) TmpLeaf;
  leaf->count = static_cast<std::uint32_t>(count);
  for (size_t i = 0; i < count; ++i) leaf->ids[i] = prims[i].primID;
  return leaf;
}

void split_primitive(const RTCBuildPrimitive* prim, unsigned int dim, float position,
                     RTCBounds* left, RTCBounds* right, void* user) {
  const auto* context = static_cast<const Context*>(user);
  const Triangle& tri = context->triangles[prim->primID];
  const Aabb box = to_aabb(*prim);
  const int axis = static_cast<int>(dim);
  Aabb l, r;
  split_triangle_bounds(tri, box, axis, position, l, r);
  // An empty side would upset Embree's bookkeeping: give it the (conservative) slab instead.
  if (l.empty()) {
    l = box;
    l.hi[axis] = std::clamp(position, box.lo[axis], box.hi[axis]);
  }
  if (r.empty()) {
    r = box;
    r.lo[axis] = std::clamp(position, box.lo[axis], box.hi[axis]);
  }
  store(l, left);
  store(r, right);
}

RTCDevice shared_device() {
  static RTCDevice device = [] {
    RTCDevice d = rtcNewDevice(nullptr);
    if (!d) throw Error("embree", "rtcNewDevice failed");
    return d;
  }();
  return device;
}

// The ids of every leaf below `node`.
void gather_ids(const TmpNode* node, std::vector<std::uint32_t>& ids) {
  if (node->leaf) {
    const auto* leaf = reinterpret_cast<const TmpLeaf*>(node);
    ids.insert(ids.end(), leaf->ids, leaf->ids + leaf->count);
    return;
  }
  const auto* inner = reinterpret_cast<const TmpInner*>(node);
  gather_ids(inner->kids[0], ids);
  gather_ids(inner->kids[1], ids);
}

// Lays the tree out from `slot` on; a subtree at depth max_depth becomes one leaf, as our own
// builders make it (Embree itself fails when its maxDepth is reached, so it builds to 64).
void lay_out(const TmpNode* node, const Aabb& box, BvhPiece& piece, std::size_t slot, int depth,
             int max_depth) {
  if (node->leaf || depth >= max_depth) {
    const auto first = static_cast<std::uint32_t>(piece.prims.size());
    gather_ids(node, piece.prims);
    std::sort(piece.prims.begin() + first, piece.prims.end());
    piece.prims.erase(std::unique(piece.prims.begin() + first, piece.prims.end()),
                      piece.prims.end());
    piece.nodes[slot] =
        BvhNode::make_leaf(box, first, static_cast<std::uint32_t>(piece.prims.size() - first));
    return;
  }
  const auto* inner = reinterpret_cast<const TmpInner*>(node);
  const auto pair = static_cast<std::uint32_t>(piece.nodes.size());
  piece.nodes.resize(pair + 2);
  const Vec3 e = box.extent();
  piece.nodes[slot] = BvhNode::make_interior(box, max_axis(e), pair);
  lay_out(inner->kids[0], inner->boxes[0], piece, pair, depth + 1, max_depth);
  lay_out(inner->kids[1], inner->boxes[1], piece, pair + 1, depth + 1, max_depth);
}

}  // namespace

BvhBuildResult build_bvh_embree(std::span<const Triangle> triangles, std::vector<BvhRef> refs,
                                const BvhBuildOptions& options, bool spatial) {
  BvhBuildResult result;
  result.root = std::make_unique<BvhPiece>();
  result.root->nodes.resize(1);
  Aabb root_box;
  for (const BvhRef& r : refs) root_box.extend(r.box);
  if (refs.empty()) return result;

  // Spatial splits need room for the extra references.
  std::vector<RTCBuildPrimitive> prims(spatial ? 2 * refs.size() : refs.size());
  for (std::size_t i = 0; i < refs.size(); ++i) {
    const Aabb& b = refs[i].box;
    prims[i] = {b.lo.x, b.lo.y, b.lo.z, 0, b.hi.x, b.hi.y, b.hi.z, refs[i].prim};
  }
  Context context{triangles};
  RTCDevice device = shared_device();
  RTCBVH bvh = rtcNewBVH(device);
  RTCBuildArguments args = rtcDefaultBuildArguments();
  args.buildQuality = spatial ? RTC_BUILD_QUALITY_HIGH : RTC_BUILD_QUALITY_MEDIUM;
  args.maxBranchingFactor = 2;
  args.sahBlockSize = static_cast<unsigned int>(std::max(options.leaf_block, 1));
  args.maxDepth = 64;
  args.minLeafSize = static_cast<unsigned int>(std::max(options.min_leaf, 1));
  args.maxLeafSize = static_cast<unsigned int>(std::clamp(options.max_leaf, 1, 32));
  args.traversalCost = options.traversal_cost;
  args.intersectionCost = options.intersection_cost;
  args.bvh = bvh;
  args.primitives = prims.data();
  args.primitiveCount = refs.size();
  args.primitiveArrayCapacity = prims.size();
  args.createNode = create_node;
  args.setNodeChildren = set_children;
  args.setNodeBounds = set_bounds;
  args.createLeaf = create_leaf;
  args.splitPrimitive = spatial ? split_primitive : nullptr;
  args.userPtr = &context;
  const void* root = rtcBuildBVH(&args);
  if (!root || rtcGetDeviceError(device) != RTC_ERROR_NONE) {
    rtcReleaseBVH(bvh);
    throw Error("embree", "rtcBuildBVH failed");
  }
  lay_out(static_cast<const TmpNode*>(root), root_box, *result.root, 0, 0,
          std::clamp(options.max_depth, 1, 64));
  rtcReleaseBVH(bvh);
  return result;
}

}  // namespace splitray

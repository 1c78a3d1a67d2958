#pragma once
// A kd node's primitives as the golden builder keeps them: triangle ids, bounds clipped to
// the node's cell, and per axis the sorted start / end / in-plane events (position plus the
// primitive's index within the node). A split hands each child its sorted events by
// filtering the parent's in order and merging in the few re-clipped straddlers, so nothing
// is sorted again below the root (as in Wald & Havran 2006's event lists).
#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>

#include "splitray/accel/kd/binned_arena.hpp"
#include "splitray/accel/kd/binned_split.hpp"
#include "splitray/accel/kd/golden_search.hpp"
#include "splitray/core/triangle.hpp"

namespace splitray {

enum EventKind { kStartEvent = 0, kEndEvent = 1, kPlaneEvent = 2 };

struct EventSpan {
  float* pos = nullptr;
  std::uint32_t* prim = nullptr;  // index of the primitive within the node
  std::size_t size = 0;
};

// Event counts of a node: [axis][kind].
using EventCounts = std::array<std::array<std::size_t, 3>, 3>;

// All arrays of one node live in one allocation (a build makes hundreds of thousands): from
// `arena` when given (released by its owner), else from the heap.
class GoldenPrims {
 public:
  GoldenPrims() = default;
  GoldenPrims(std::size_t prims, const EventCounts& counts, BumpArena* arena = nullptr);

  std::size_t size() const { return size_; }
  std::span<std::uint32_t> ids() const { return {ids_, size_}; }
  std::span<Aabb> bounds() const { return {bounds_, size_}; }
  const EventSpan& events(int axis, int kind) const { return events_[axis][kind]; }
  AxisEvents axis_events(int axis) const;
  void release() {
    storage_.reset();
    size_ = 0;
  }

 private:
  std::unique_ptr<std::byte[]> storage_;
  std::size_t size_ = 0;
  std::uint32_t* ids_ = nullptr;
  Aabb* bounds_ = nullptr;
  std::array<std::array<EventSpan, 3>, 3> events_{};
};

// The root: every triangle with finite bounds, clipped to `cell` (its bounds ∩ cell).
GoldenPrims make_golden_prims(std::span<const Triangle> triangles, const Aabb& cell, bool parallel);

// A node's primitives (bounds already clipped to its cell) with their lists sorted on the
// spot: predicted rebuilds keep nodes without lists and make them where a search needs them.
GoldenPrims make_golden_prims(std::span<const PrimRef> refs, BumpArena* arena);

struct GoldenSplitOptions {
  bool parallel = false;         // split the lists of a large node in parallel
  BumpArena* nodes = nullptr;    // where the children's arrays go (else the heap)
  BumpArena* scratch = nullptr;  // temporary arrays, released on return (else the heap)
  std::size_t events_from = 0;   // children with at most this many prims get no events
};

// Splits `node` (released on return) at `position` on `axis` into the primitives of the
// cells below and above. Straddlers go to both sides with bounds re-clipped to each child
// cell (perfect splits); primitives in the plane go below when planar_below, else above.
// A child that will be a leaf anyway (options.events_from) gets ids and bounds only.
void split_golden_prims(GoldenPrims& node, std::span<const Triangle> triangles, const Aabb& cell,
                        int axis, float position, bool planar_below, GoldenPrims& below,
                        GoldenPrims& above, const GoldenSplitOptions& options = {});

}  // namespace splitray

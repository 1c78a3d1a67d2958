#pragma once
// One-dimensional search for the SAH-optimal split position on one axis of a kd node, by
// golden-section search combined with parabolic interpolation (Brent), as in Hussain &
// Grahn 2007 and paper 000 §5. The left/right primitive counts at a probe position come
// in O(log n) from binary searches in the node's sorted event positions.
//
// The SAH over the split position is piecewise linear with jumps at the events (the
// primitives' clipped bounds), and its minimum is always attained at an event: with the
// counting below (start < p below, end > p above) the cost at an event is no larger than
// its limits on either side. So every search ends by "snapping" its best probe to the two
// neighbouring events, and a tiny axis is simply scanned event by event.
#include <cstddef>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>

#include "splitray/accel/kd/kd_sah.hpp"
#include "splitray/core/aabb.hpp"

namespace splitray {

// The sorted events of a node's primitives on one axis (clipped bounds, ascending).
struct AxisEvents {
  std::span<const float> starts;  // lo of the primitives with lo < hi on this axis
  std::span<const float> ends;    // hi of those primitives
  std::span<const float> planes;  // position of the primitives with lo == hi (in-plane)
  // Lists restricted to a bracket [lo, hi] (predicted rebuilds) leave out the primitives
  // below every position of it (counted below) and those above (counted above).
  std::size_t below_before = 0, above_after = 0;

  std::size_t prims() const { return starts.size() + planes.size(); }
  std::size_t events() const { return starts.size() + ends.size() + planes.size(); }
};

// A split position and what it costs. Primitives lying in the plane go below when
// planar_below, else above; every other primitive goes where its bounds are (both sides
// when it straddles the plane).
struct SplitCandidate {
  float position = 0;
  double cost = std::numeric_limits<double>::infinity();
  std::size_t n_below = 0, n_above = 0;
  bool planar_below = true;

  bool valid() const { return cost < std::numeric_limits<double>::infinity(); }
};

struct GoldenSearchOptions {
  int samples = 8;          // coarse uniform samples that bracket the minimum (no start given)
  double tolerance = 2e-3;  // final bracket width, relative to the searched interval
  int max_iterations = 40;  // Brent iterations at most
  std::size_t exhaustive_events = 128;  // axes with at most this many events are swept fully
};

struct GoldenSearchResult {
  SplitCandidate best;      // invalid when no position strictly inside the cell was allowed
  std::uint32_t evals = 0;  // SAH cost evaluations made
  // The best lies at or beyond lo or hi (snapping to an event may leave the bracket) where
  // that is not the cell's face: the caller may widen the search.
  bool at_bracket_edge = false;
};

// SAH cost of splitting `cell` at `position` (strictly inside the cell) on `axis`. When
// primitives lie in the plane both placements are costed and the cheaper kept (ties: below).
// Adds the number of cost evaluations (1 or 2) to `evals`.
SplitCandidate evaluate_split(const AxisEvents& events, const Aabb& cell, int axis,
                              const KdSplitCost& cost, float position, std::uint32_t& evals);

// The best split position on `axis` within [lo, hi] ∩ open cell interval, or at a face the
// bracket reaches that holds in-plane primitives (kd_sah.hpp). Without `start`:
// coarse samples (plus the two empty-space cuts at the content's bounds) bracket the
// minimum, Brent refines inside the bracket around the best sample. With `start` (e.g. a
// position predicted from the previous frame of an animation, issue #4): Brent starts at
// `start` inside [lo, hi] directly, and at_bracket_edge tells whether the bracket was too
// narrow. Either way the best probe is snapped to its neighbouring events.
GoldenSearchResult golden_search_axis(const AxisEvents& events, const Aabb& cell, int axis,
                                      const KdSplitCost& cost, float lo, float hi,
                                      std::optional<float> start = std::nullopt,
                                      const GoldenSearchOptions& options = {});

// The exact minimum: one sweep costing every distinct event position in [lo, hi] inside the
// cell, and the faces of the cell in [lo, hi] that hold in-plane primitives (kd_sah.hpp's
// planar rule; ties: lowest position). Used for axes with few events and the tests.
GoldenSearchResult exhaustive_search_axis(const AxisEvents& events, const Aabb& cell, int axis,
                                          const KdSplitCost& cost, float lo, float hi);

}  // namespace splitray

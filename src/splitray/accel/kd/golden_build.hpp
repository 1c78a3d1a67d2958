#pragma once
// The golden builder's recursion, shared by `--builder golden` and the predicted rebuilds of
// animations (predicted_builder.hpp): with a SplitPredictor, a node the predictor knows
// first searches its predicted bracket (paper 000, Algorithm 1); without one, or where no
// prediction exists, every node runs golden's full search, so the trees agree.
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "splitray/accel/kd/binned_arena.hpp"
#include "splitray/accel/kd/binned_split.hpp"
#include "splitray/accel/kd/golden_search.hpp"
#include "splitray/accel/kd/kd_build.hpp"
#include "splitray/accel/kd/kd_emit.hpp"
#include "splitray/accel/predict/split_predictor.hpp"

namespace splitray {

// What a predicted build saw at one node it searched (nodes of more than 64 primitives).
struct GoldenNodeRecord {
  SplitObservation observation;
  std::optional<SplitPrediction> prediction;
  bool used_prediction = false, fell_back = false;
};

// Builds the golden tree of `triangles` in `cell`, steered by `predictor` when given; the
// searched nodes' records go to `records` (sorted by path) when given.
KdBuildResult build_kd_golden_steered(std::span<const Triangle> triangles, const Aabb& cell,
                                      const BuildConfig& config, const SplitPredictor* predictor,
                                      std::vector<GoldenNodeRecord>* records);

// Golden's subtree of one node given as PrimRefs (bounds clipped to `cell`) at `depth` of a
// tree over `tree_prims` triangles (which sets the depth limit), built sequentially and
// appended to `out`; returns the cost evaluations. Coherent rebuilds (coherent_builder.hpp)
// rebuild drifted subtrees with it.
std::uint64_t build_kd_golden_refs(std::span<const PrimRef> prims,
                                   std::span<const Triangle> triangles, const Aabb& cell, int depth,
                                   std::size_t tree_prims, const BuildConfig& config, KdChunk& out);

// The SAH minimum on `axis` within [lo, hi] of a node kept as PrimRefs (no sorted lists),
// searched from `start` (golden_search_axis); `scratch` holds the bracket's events.
GoldenSearchResult search_bracket_refs(std::span<const PrimRef> prims, const Aabb& cell, int axis,
                                       const KdSplitCost& cost, float lo, float hi, float start,
                                       BumpArena& scratch);

}  // namespace splitray

#include "splitray/accel/kd/golden_search.hpp"

#include <algorithm>
#include <cmath>

namespace splitray {

namespace {

constexpr double kGolden = 0.3819660112501051;  // (3 - sqrt 5) / 2
constexpr double kInf = std::numeric_limits<double>::infinity();

std::size_t count_less(std::span<const float> v, float p) {
  return static_cast<std::size_t>(std::lower_bound(v.begin(), v.end(), p) - v.begin());
}
std::size_t count_less_equal(std::span<const float> v, float p) {
  return static_cast<std::size_t>(std::upper_bound(v.begin(), v.end(), p) - v.begin());
}
bool contains(std::span<const float> v, float p) {
  return std::binary_search(v.begin(), v.end(), p);
}

// Deterministic order of candidates: cost, then position.
bool better(const SplitCandidate& a, const SplitCandidate& b) {
  return a.cost < b.cost || (a.cost == b.cost && a.valid() && a.position < b.position);
}

// The cost of a split with `below` / `above` primitives on either side and `planar` in the
// plane, which go to the cheaper side (ties: below).
SplitCandidate cost_split(const KdAxisCost& cost, float position, std::size_t below,
                          std::size_t above, std::size_t planar, std::uint32_t& evals) {
  SplitCandidate c;
  c.position = position;
  c.n_below = below + planar;
  c.n_above = above;
  c.cost = cost(position, c.n_below, c.n_above);
  ++evals;
  if (planar > 0) {
    const double cost_above = cost(position, below, above + planar);
    ++evals;
    if (cost_above < c.cost) {
      c.cost = cost_above;
      c.n_below = below;
      c.n_above = above + planar;
      c.planar_below = false;
    }
  }
  return c;
}

// The counts at `position` by binary search, and the cost.
SplitCandidate count_and_cost(const AxisEvents& events, const KdAxisCost& cost, float position,
                              std::uint32_t& evals) {
  const std::size_t planes_below = count_less(events.planes, position);
  const std::size_t planes_at = count_less_equal(events.planes, position) - planes_below;
  const std::size_t below =
      count_less(events.starts, position) + planes_below + events.below_before;
  const std::size_t above = (events.ends.size() - count_less_equal(events.ends, position)) +
                            (events.planes.size() - planes_below - planes_at) + events.above_after;
  return cost_split(cost, position, below, above, planes_at, evals);
}

// Evaluates probes and keeps the best one; positions outside the open cell cost infinity.
class Probe {
 public:
  Probe(const AxisEvents& events, const Aabb& cell, int axis, const KdSplitCost& cost,
        GoldenSearchResult& result)
      : events_(events), cell_(cell), axis_(axis), cost_(cost, cell, axis), result_(result) {}

  bool allowed(float p) const { return p > cell_.lo[axis_] && p < cell_.hi[axis_]; }

  double operator()(double x) {
    const float p = static_cast<float>(x);
    if (!allowed(p)) return kInf;
    const SplitCandidate c = count_and_cost(events_, cost_, p, result_.evals);
    if (better(c, result_.best)) result_.best = c;
    return c.cost;
  }

 private:
  const AxisEvents& events_;
  const Aabb& cell_;
  int axis_;
  KdAxisCost cost_;
  GoldenSearchResult& result_;
};

// Brent's localmin over [a, b] from the interior point x (f(x) = fx known): golden-section
// steps, replaced by parabolic steps where the parabola through the last three points is
// trustworthy. Stops when the bracket is narrower than about 4 * tol.
void brent(Probe& f, double a, double b, double x, double fx, double tol_abs, int max_iterations) {
  double w = x, v = x, fw = fx, fv = fx, d = 0, e = 0;
  for (int it = 0; it < max_iterations; ++it) {
    const double m = 0.5 * (a + b);
    const double tol = tol_abs + 1e-7 * std::fabs(x);  // never below float resolution
    const double t2 = 2 * tol;
    if (std::fabs(x - m) <= t2 - 0.5 * (b - a)) break;
    bool golden = true;
    if (std::fabs(e) > tol && std::isfinite(fx) && std::isfinite(fw) && std::isfinite(fv)) {
      double r = (x - w) * (fx - fv);
      double q = (x - v) * (fx - fw);
      double p = (x - v) * q - (x - w) * r;
      q = 2 * (q - r);
      if (q > 0)
        p = -p;
      else
        q = -q;
      const double e_prev = e;
      e = d;
      if (std::fabs(p) < std::fabs(0.5 * q * e_prev) && p > q * (a - x) && p < q * (b - x)) {
        d = p / q;
        const double u = x + d;
        if (u - a < t2 || b - u < t2) d = x < m ? tol : -tol;
        golden = false;
      }
    }
    if (golden) {
      e = (x < m ? b : a) - x;
      d = kGolden * e;
    }
    const double u = std::fabs(d) >= tol ? x + d : x + (d > 0 ? tol : -tol);
    const double fu = f(u);
    if (fu <= fx) {
      if (u < x)
        b = x;
      else
        a = x;
      v = w;
      fv = fw;
      w = x;
      fw = fx;
      x = u;
      fx = fu;
    } else {
      if (u < x)
        a = u;
      else
        b = u;
      if (fu <= fw || w == x) {
        v = w;
        fv = fw;
        w = u;
        fw = fu;
      } else if (fu <= fv || v == x || v == w) {
        v = u;
        fv = fu;
      }
    }
  }
}

// The cost is linear between neighbouring events and no larger at an event than beside
// it, so a probe between events is never better than the better of its two neighbours.
void snap_to_events(const AxisEvents& events, Probe& f, float x) {
  const std::span<const float> lists[3] = {events.starts, events.ends, events.planes};
  float prev = -std::numeric_limits<float>::infinity(),
        next = std::numeric_limits<float>::infinity();
  for (const auto& list : lists) {
    if (contains(list, x)) return;  // already an event
    const auto it = std::lower_bound(list.begin(), list.end(), x);
    if (it != list.begin()) prev = std::max(prev, *(it - 1));
    if (it != list.end()) next = std::min(next, *it);
  }
  if (f.allowed(prev)) f(prev);
  if (f.allowed(next)) f(next);
}

}  // namespace

SplitCandidate evaluate_split(const AxisEvents& events, const Aabb& cell, int axis,
                              const KdSplitCost& cost, float position, std::uint32_t& evals) {
  return count_and_cost(events, KdAxisCost(cost, cell, axis), position, evals);
}

GoldenSearchResult exhaustive_search_axis(const AxisEvents& events, const Aabb& cell, int axis,
                                          const KdSplitCost& cost, float lo, float hi) {
  // One sweep over the three sorted lists, keeping the counts on either side current.
  // (The hot loop of small nodes: plain indices, and the candidate kept as scalars.)
  GoldenSearchResult result;
  const float* starts = events.starts.data();
  const float* ends = events.ends.data();
  const float* planes = events.planes.data();
  const std::size_t n_starts = events.starts.size(), n_ends = events.ends.size(),
                    n_planes = events.planes.size();
  const KdAxisCost axis_cost(cost, cell, axis);
  const float cell_lo = cell.lo[axis], cell_hi = cell.hi[axis];
  std::size_t i = 0, j = 0, k = 0;
  std::size_t below = events.below_before, above = n_ends + n_planes + events.above_after;
  double best = kInf;
  float best_position = 0;
  std::size_t best_below = 0, best_above = 0;
  bool best_planar_below = true;
  std::uint32_t evals = 0;
  const auto consider = [&](float p, std::size_t n_below, std::size_t n_above, bool planar_below) {
    const double c = axis_cost(p, n_below, n_above);
    ++evals;
    if (c < best) {
      best = c;
      best_position = p;
      best_below = n_below;
      best_above = n_above;
      best_planar_below = planar_below;
    }
  };
  constexpr float kNone = std::numeric_limits<float>::infinity();
  while (true) {
    float p = i < n_starts ? starts[i] : kNone;
    if (j < n_ends && ends[j] < p) p = ends[j];
    if (k < n_planes && planes[k] < p) p = planes[k];
    if (!(p <= hi)) break;
    const std::size_t i0 = i, j0 = j, k0 = k;
    while (i < n_starts && starts[i] == p) ++i;
    while (j < n_ends && ends[j] == p) ++j;
    while (k < n_planes && planes[k] == p) ++k;
    const std::size_t planar = k - k0;
    above -= (j - j0) + planar;
    if (p >= lo && p > cell_lo && p < cell_hi) {
      consider(p, below + planar, above, true);
      if (planar > 0) consider(p, below, above + planar, false);
    } else if (planar > 0 && p >= lo && cell_lo < cell_hi) {
      // The planar rule at a face (kd_sah.hpp): the primitives lying in it go into a flat cell.
      if (p == cell_lo) consider(p, below + planar, above, true);
      if (p == cell_hi) consider(p, below, above + planar, false);
    }
    below += (i - i0) + planar;
  }
  result.evals = evals;
  if (best < kInf) {
    result.best.position = best_position;
    result.best.cost = best;
    result.best.n_below = best_below;
    result.best.n_above = best_above;
    result.best.planar_below = best_planar_below;
  }
  return result;
}

GoldenSearchResult golden_search_axis(const AxisEvents& events, const Aabb& cell, int axis,
                                      const KdSplitCost& cost, float lo, float hi,
                                      std::optional<float> start,
                                      const GoldenSearchOptions& options) {
  lo = std::max(lo, cell.lo[axis]);
  hi = std::min(hi, cell.hi[axis]);
  if (!(lo < hi) || events.events() == 0) return {};
  const double width = static_cast<double>(hi) - lo;
  const double tol = options.tolerance * width;
  const auto flag_edge = [&](GoldenSearchResult& r) {
    const float p = r.best.position;
    r.at_bracket_edge = r.best.valid() && ((lo > cell.lo[axis] && p <= lo + 2 * tol) ||
                                           (hi < cell.hi[axis] && p >= hi - 2 * tol));
  };
  if (events.events() <= options.exhaustive_events) {
    GoldenSearchResult r = exhaustive_search_axis(events, cell, axis, cost, lo, hi);
    flag_edge(r);
    return r;
  }

  GoldenSearchResult result;
  Probe f(events, cell, axis, cost, result);
  // The planar rule at the faces the bracket reaches (kd_sah.hpp), costed exactly.
  {
    const KdAxisCost axis_cost(cost, cell, axis);
    const std::size_t n = events.prims() + events.below_before + events.above_after;
    const std::size_t at_lo = count_less_equal(events.planes, cell.lo[axis]);
    const std::size_t at_hi = events.planes.size() - count_less(events.planes, cell.hi[axis]);
    SplitCandidate c;
    if (lo == cell.lo[axis] && at_lo > 0 && events.below_before == 0) {
      c = {cell.lo[axis], axis_cost(cell.lo[axis], at_lo, n - at_lo), at_lo, n - at_lo, true};
      ++result.evals;
      if (better(c, result.best)) result.best = c;
    }
    if (hi == cell.hi[axis] && at_hi > 0 && events.above_after == 0) {
      c = {cell.hi[axis], axis_cost(cell.hi[axis], n - at_hi, at_hi), n - at_hi, at_hi, false};
      ++result.evals;
      if (better(c, result.best)) result.best = c;
    }
  }
  double a = lo, b = hi, x, fx;
  if (start) {
    x = std::clamp(static_cast<double>(*start), a + 0.5 * tol, b - 0.5 * tol);
    fx = f(x);
  } else {
    // Empty-space cuts at the content's bounds: the SAH's empty bonus often makes them the
    // best splits, and they sit where a smooth search does not look.
    float content_lo = std::numeric_limits<float>::infinity(), content_hi = -content_lo;
    if (!events.starts.empty()) content_lo = events.starts.front(), content_hi = events.ends.back();
    if (!events.planes.empty()) {
      content_lo = std::min(content_lo, events.planes.front());
      content_hi = std::max(content_hi, events.planes.back());
    }
    if (content_lo >= lo) f(content_lo);
    if (content_hi <= hi) f(content_hi);
    // Coarse samples bracket the minimum; Brent then works between the best one's neighbours.
    const int samples = std::max(options.samples, 1);
    int best = 0;
    double best_cost = kInf;
    for (int k = 1; k <= samples; ++k) {
      const double c = f(lo + width * k / (samples + 1));
      if (c < best_cost) best_cost = c, best = k;
    }
    if (best == 0) best = (samples + 1) / 2;
    a = lo + width * (best - 1) / (samples + 1);
    b = lo + width * (best + 1) / (samples + 1);
    x = lo + width * best / (samples + 1);
    fx = best_cost;
  }
  brent(f, a, b, x, fx, tol, options.max_iterations);
  if (result.best.valid()) snap_to_events(events, f, result.best.position);
  flag_edge(result);
  return result;
}

}  // namespace splitray

#include "splitray/accel/kd/golden_events.hpp"

#include <algorithm>
#include <bit>
#include <vector>

#include "splitray/accel/triangle_clip.hpp"
#include "splitray/core/parallel.hpp"

namespace splitray {

namespace {

constexpr std::size_t kParallelGrain = 4096;

// Floats as unsigned keys with the same order (-0 sorts just before +0, which compare equal).
std::uint32_t order_key(float f) {
  const std::uint32_t u = std::bit_cast<std::uint32_t>(f);
  return (u & 0x80000000u) ? ~u : (u | 0x80000000u);
}
float from_key(std::uint32_t k) {
  return std::bit_cast<float>((k & 0x80000000u) ? (k & 0x7fffffffu) : ~k);
}
std::uint64_t event_key(float pos, std::uint32_t prim) {
  return (static_cast<std::uint64_t>(order_key(pos)) << 32) | prim;
}

// Sorts (position key << 32 | prim) events. Large lists must arrive in prim order: the
// radix sort is stable and sorts by position only.
void sort_events(std::uint64_t* keys, std::size_t n) {
  if (n < 512) {
    std::sort(keys, keys + n);
    return;
  }
  std::vector<std::uint64_t> tmp(n);
  std::uint64_t* from = keys;
  std::uint64_t* to = tmp.data();
  for (const int shift : {32, 43, 54}) {
    std::size_t count[2049] = {};
    for (std::size_t i = 0; i < n; ++i) ++count[((from[i] >> shift) & 2047u) + 1];
    for (int b = 0; b < 2048; ++b) count[b + 1] += count[b];
    for (std::size_t i = 0; i < n; ++i) to[count[(from[i] >> shift) & 2047u]++] = from[i];
    std::swap(from, to);
  }
  if (from != keys) std::copy(from, from + n, keys);
}

bool planar(const Aabb& b, int axis) { return b.lo[axis] == b.hi[axis]; }

// The event of `kind` of a primitive with bounds `b` on `axis`, if it has one.
bool event_of(const Aabb& b, int axis, int kind, float& pos) {
  const bool flat = planar(b, axis);
  if (kind == kPlaneEvent) {
    pos = b.lo[axis];
    return flat;
  }
  pos = kind == kStartEvent ? b.lo[axis] : b.hi[axis];
  return !flat;
}

void count_events(const Aabb& b, EventCounts& counts) {
  for (int axis = 0; axis < 3; ++axis) {
    if (planar(b, axis)) {
      ++counts[axis][kPlaneEvent];
    } else {
      ++counts[axis][kStartEvent];
      ++counts[axis][kEndEvent];
    }
  }
}

}  // namespace

GoldenPrims::GoldenPrims(std::size_t prims, const EventCounts& counts, BumpArena* arena)
    : size_(prims) {
  std::size_t words = prims * (1 + sizeof(Aabb) / 4);
  for (const auto& axis : counts)
    for (const std::size_t c : axis) words += 2 * c;
  static_assert(sizeof(Aabb) == 24 && alignof(Aabb) == 4 && sizeof(float) == 4);
  std::byte* at;
  if (arena) {
    at = arena->allocate<std::byte>(words * 4);
  } else {
    storage_ = std::make_unique_for_overwrite<std::byte[]>(words * 4);
    at = storage_.get();
  }
  ids_ = reinterpret_cast<std::uint32_t*>(at);
  at += prims * 4;
  bounds_ = reinterpret_cast<Aabb*>(at);
  at += prims * sizeof(Aabb);
  for (int axis = 0; axis < 3; ++axis) {
    for (int kind = 0; kind < 3; ++kind) {
      EventSpan& e = events_[axis][kind];
      e.size = counts[axis][kind];
      e.pos = reinterpret_cast<float*>(at);
      at += e.size * 4;
      e.prim = reinterpret_cast<std::uint32_t*>(at);
      at += e.size * 4;
    }
  }
}

AxisEvents GoldenPrims::axis_events(int axis) const {
  const auto list = [&](int kind) {
    const EventSpan& e = events_[axis][kind];
    return std::span<const float>(e.pos, e.size);
  };
  return {list(kStartEvent), list(kEndEvent), list(kPlaneEvent)};
}

GoldenPrims make_golden_prims(std::span<const Triangle> triangles, const Aabb& cell,
                              bool parallel) {
  std::vector<std::uint32_t> ids;
  std::vector<Aabb> bounds;
  ids.reserve(triangles.size());
  bounds.reserve(triangles.size());
  EventCounts counts{};
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    const Aabb b = triangles[i].bounds();
    if (!is_finite(b.lo) || !is_finite(b.hi)) continue;  // never hit: leave it out
    const Aabb clipped = intersection(b, cell);
    if (clipped.empty()) continue;
    ids.push_back(static_cast<std::uint32_t>(i));
    bounds.push_back(clipped);
    count_events(clipped, counts);
  }
  GoldenPrims prims(ids.size(), counts);
  std::copy(ids.begin(), ids.end(), prims.ids().begin());
  std::copy(bounds.begin(), bounds.end(), prims.bounds().begin());
  const auto fill = [&](std::size_t list) {
    const int axis = static_cast<int>(list / 3), kind = static_cast<int>(list % 3);
    std::vector<std::uint64_t> keys;
    keys.reserve(counts[axis][kind]);
    float pos;
    for (std::size_t i = 0; i < bounds.size(); ++i)
      if (event_of(bounds[i], axis, kind, pos))
        keys.push_back(event_key(pos, static_cast<std::uint32_t>(i)));
    sort_events(keys.data(), keys.size());
    const EventSpan& e = prims.events(axis, kind);
    for (std::size_t j = 0; j < keys.size(); ++j) {
      e.pos[j] = from_key(static_cast<std::uint32_t>(keys[j] >> 32));
      e.prim[j] = static_cast<std::uint32_t>(keys[j]);
    }
  };
  if (parallel) {
    parallel_for_each_index(std::size_t{9}, fill);
  } else {
    for (std::size_t list = 0; list < 9; ++list) fill(list);
  }
  return prims;
}

GoldenPrims make_golden_prims(std::span<const PrimRef> refs, BumpArena* arena) {
  EventCounts counts{};
  for (const PrimRef& r : refs) count_events(r.bounds, counts);
  GoldenPrims prims(refs.size(), counts, arena);
  for (std::size_t i = 0; i < refs.size(); ++i) {
    prims.ids()[i] = refs[i].id;
    prims.bounds()[i] = refs[i].bounds;
  }
  thread_local std::vector<std::uint64_t> keys;
  for (int axis = 0; axis < 3; ++axis) {
    for (int kind = 0; kind < 3; ++kind) {
      keys.clear();
      float pos;
      for (std::size_t i = 0; i < refs.size(); ++i)
        if (event_of(refs[i].bounds, axis, kind, pos))
          keys.push_back(event_key(pos, static_cast<std::uint32_t>(i)));
      sort_events(keys.data(), keys.size());
      const EventSpan& e = prims.events(axis, kind);
      for (std::size_t j = 0; j < keys.size(); ++j) {
        e.pos[j] = from_key(static_cast<std::uint32_t>(keys[j] >> 32));
        e.prim[j] = static_cast<std::uint32_t>(keys[j]);
      }
    }
  }
  return prims;
}

namespace {

// Temporary arrays of a split: from the scratch arena when there is one, else the heap.
class Scratch {
 public:
  explicit Scratch(BumpArena* arena)
      : arena_(arena), mark_(arena ? arena->mark() : BumpArena::Mark{}) {}
  ~Scratch() {
    if (arena_) arena_->release(mark_);
  }
  template <typename T>
  T* get(std::size_t count) {
    if (arena_) return arena_->allocate<T>(count);
    heap_.push_back(std::make_unique_for_overwrite<std::byte[]>(count * sizeof(T)));
    return reinterpret_cast<T*>(heap_.back().get());
  }

 private:
  BumpArena* arena_;
  BumpArena::Mark mark_;
  std::vector<std::unique_ptr<std::byte[]>> heap_;
};

}  // namespace

void split_golden_prims(GoldenPrims& node, std::span<const Triangle> triangles, const Aabb& cell,
                        int axis, float position, bool planar_below, GoldenPrims& below,
                        GoldenPrims& above, const GoldenSplitOptions& options) {
  const std::size_t n = node.size();
  const auto ids = node.ids();
  const auto bounds = node.bounds();
  const bool parallel = options.parallel;
  Scratch scratch(options.scratch);

  // 1. Sides, from the clipped bounds on the split axis.
  std::uint8_t* side = scratch.get<std::uint8_t>(n);
  const auto classify = [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const float lo = bounds[i].lo[axis], hi = bounds[i].hi[axis];
      if (lo == position && hi == position)
        side[i] = planar_below ? kBelow : kAbove;
      else if (lo < position && hi > position)
        side[i] = kBoth;
      else if (lo < position)
        side[i] = kBelow;
      else
        side[i] = kAbove;
    }
  };
  if (parallel)
    parallel_chunks(n, kParallelGrain, classify);
  else
    classify(0, n);

  // 2. Indices within the children (parent order kept): remap[i] is the index of a
  // one-sided primitive in its child; straddlers are listed apart with both indices.
  std::uint32_t* remap = scratch.get<std::uint32_t>(n);
  std::size_t n_straddlers = 0;
  for (std::size_t i = 0; i < n; ++i) n_straddlers += side[i] == kBoth;
  std::uint32_t* straddlers = scratch.get<std::uint32_t>(n_straddlers);           // parent index
  std::uint32_t* straddler_index = scratch.get<std::uint32_t>(2 * n_straddlers);  // below, above
  std::size_t n_below = 0, n_above = 0, s = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (side[i] == kBoth) {
      straddlers[s] = static_cast<std::uint32_t>(i);
      straddler_index[2 * s] = static_cast<std::uint32_t>(n_below++);
      straddler_index[2 * s + 1] = static_cast<std::uint32_t>(n_above++);
      ++s;
    } else {
      remap[i] = static_cast<std::uint32_t>(side[i] == kBelow ? n_below++ : n_above++);
    }
  }

  // 3. Straddlers, re-clipped to each child cell.
  Aabb below_cell = cell, above_cell = cell;
  below_cell.hi[axis] = position;
  above_cell.lo[axis] = position;
  Aabb* clipped = scratch.get<Aabb>(2 * n_straddlers);  // below, above
  const auto clip = [&](std::size_t begin, std::size_t end) {
    for (std::size_t k = begin; k < end; ++k) {
      const Triangle& t = triangles[ids[straddlers[k]]];
      clip_triangle_split(t, cell, bounds[straddlers[k]], axis, position, clipped[2 * k],
                          clipped[2 * k + 1], ClipTightness::slab);
    }
  };
  if (parallel)
    parallel_chunks(n_straddlers, 256, clip);
  else
    clip(0, n_straddlers);

  // 4. The children's ids, bounds and event counts (none for a child that will be a leaf).
  const bool events[2] = {n_below > options.events_from, n_above > options.events_from};
  EventCounts counts[2] = {};
  for (std::size_t i = 0; i < n; ++i)
    if (side[i] != kBoth && events[side[i] == kAbove])
      count_events(bounds[i], counts[side[i] == kAbove]);
  for (std::size_t k = 0; k < n_straddlers; ++k)
    for (int c = 0; c < 2; ++c)
      if (events[c]) count_events(clipped[2 * k + c], counts[c]);
  below = GoldenPrims(n_below, counts[0], options.nodes);
  above = GoldenPrims(n_above, counts[1], options.nodes);
  GoldenPrims* children[2] = {&below, &above};
  for (std::size_t i = 0; i < n; ++i) {
    if (side[i] == kBoth) continue;
    GoldenPrims& child = *children[side[i] == kAbove];
    child.ids()[remap[i]] = ids[i];
    child.bounds()[remap[i]] = bounds[i];
  }
  for (std::size_t k = 0; k < n_straddlers; ++k) {
    for (int c = 0; c < 2; ++c) {
      children[c]->ids()[straddler_index[2 * k + c]] = ids[straddlers[k]];
      children[c]->bounds()[straddler_index[2 * k + c]] = clipped[2 * k + c];
    }
  }

  // 5. Each sorted list: the one-sided primitives' events in order (one pass for both
  // children), merged with the straddlers' new events, sorted apart (there are few).
  if (!events[0] && !events[1]) {
    node.release();
    return;
  }
  const auto make_list = [&](std::size_t list, std::uint64_t* extra) {
    const int ax = static_cast<int>(list / 3), kind = static_cast<int>(list % 3);
    const EventSpan& from = node.events(ax, kind);
    const EventSpan* to[2] = {&below.events(ax, kind), &above.events(ax, kind)};
    std::size_t f[2] = {0, 0};
    for (std::size_t j = 0; j < from.size; ++j) {
      const std::uint32_t i = from.prim[j];
      const std::uint8_t sd = side[i];
      if (sd == kBoth) continue;
      const int c = sd == kAbove;
      if (!events[c]) continue;
      to[c]->pos[f[c]] = from.pos[j];
      to[c]->prim[f[c]] = remap[i];
      ++f[c];
    }
    for (int c = 0; c < 2; ++c) {
      if (!events[c] || n_straddlers == 0) continue;
      const EventSpan& into = *to[c];
      std::size_t m = 0;
      float pos;
      for (std::size_t k = 0; k < n_straddlers; ++k)
        if (event_of(clipped[2 * k + c], ax, kind, pos))
          extra[m++] = event_key(pos, straddler_index[2 * k + c]);
      sort_events(extra, m);
      // Merge from the back, in place.
      std::size_t out = f[c] + m, a = f[c], b = m;
      while (b > 0) {
        --out;
        if (a > 0 && event_key(into.pos[a - 1], into.prim[a - 1]) > extra[b - 1]) {
          --a;
          into.pos[out] = into.pos[a];
          into.prim[out] = into.prim[a];
        } else {
          --b;
          into.pos[out] = from_key(static_cast<std::uint32_t>(extra[b] >> 32));
          into.prim[out] = static_cast<std::uint32_t>(extra[b]);
        }
      }
    }
  };
  if (parallel) {
    parallel_for_each_index(std::size_t{9}, [&](std::size_t list) {
      std::vector<std::uint64_t> extra(n_straddlers);
      make_list(list, extra.data());
    });
  } else {
    std::uint64_t* extra = scratch.get<std::uint64_t>(n_straddlers);
    for (std::size_t list = 0; list < 9; ++list) make_list(list, extra);
  }
  node.release();
}

}  // namespace splitray

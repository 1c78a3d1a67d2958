#pragma once
// The stack of a front-to-back traversal (kd-tree, BIH, BVH, and their packets): the cells or
// nodes a ray also reaches, pushed farther first, so that the nearest is popped first.
//
// The culled pop: a popped entry whose entry t lies behind the closest hit found since it was
// pushed cannot hold a closer hit and is dropped; one whose entry t equals the hit's is kept,
// because a triangle there at the same t with a smaller id wins the tie (Hit::closer_than), as
// in `brute`. Any-hit queries pass tmax (their hit.t), which no pushed entry starts behind.
namespace splitray {

// Entry: a copyable record whose entry parameter is the member `t0`. At most kCapacity pushes
// without a pop (the caller's depth bound).
template <class Entry, int kCapacity>
class TraversalStack {
 public:
  bool empty() const { return top_ == 0; }
  int size() const { return top_; }
  void push(const Entry& entry) { entries_[top_++] = entry; }
  // Pushes `entry` among those pushed since the stack held `mark` entries, keeping them ordered
  // farther first (larger t0 lower), so that a node's nearer children are popped first (the
  // wide BVH pushes every child a ray enters but the nearest, in any order).
  void push_ordered(const Entry& entry, int mark) {
    int j = top_++;
    for (; j > mark && entries_[j - 1].t0 < entry.t0; --j) entries_[j] = entries_[j - 1];
    entries_[j] = entry;
  }

  // Pops entries until `keep(entry)` holds and returns that entry (valid until the next push),
  // or nullptr when the stack runs out first.
  template <class Keep>
  const Entry* pop_until(Keep keep) {
    while (top_ > 0) {
      const Entry& entry = entries_[--top_];
      if (keep(entry)) return &entry;
    }
    return nullptr;
  }

  // The nearest entry not behind the closest hit at `t` (entry.t0 <= t; a NaN t0 is behind).
  const Entry* pop_not_behind(float t) {
    return pop_until([t](const Entry& entry) { return entry.t0 <= t; });
  }

 private:
  Entry entries_[kCapacity];  // not initialised: only pushed entries are read
  int top_ = 0;
};

}  // namespace splitray

#pragma once
// The stack of a front-to-back traversal (kd-tree, BIH, kd packets): the cells or nodes a ray
// also reaches, pushed farther first, so that the nearest is popped first.
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
  void push(const Entry& entry) { entries_[top_++] = entry; }

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

#pragma once
// Batched queries over all cores (internal): fixed chunks of a processing order, so results
// never depend on the thread count.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "splitray/core/parallel.hpp"
#include "splitray/query/neighbors.hpp"
#include "splitray/query/result_sets.hpp"

namespace splitray::detail {

inline constexpr std::size_t kQueryChunk = 1024;

// Calls one(q, queries[q]) for every query, visiting them in `order` (empty: 0 .. n - 1).
// Each chunk first copies its queries into a local block: independent loads overlap their
// cache misses, where a search that loads its own scattered query would stall on it.
template <typename One>
void for_each_query(std::span<const Vec3> queries, const std::vector<std::uint32_t>& order,
                    const One& one) {
  parallel_chunks(queries.size(), kQueryChunk, [&](std::size_t b, std::size_t e) {
    Vec3 block[kQueryChunk];
    for (std::size_t s = b; s < e; s += kQueryChunk) {
      const std::size_t t = std::min(e, s + kQueryChunk);
      if (order.empty()) {
        for (std::size_t j = s; j < t; ++j) one(j, queries[j]);
        continue;
      }
      for (std::size_t j = s; j < t; ++j) block[j - s] = queries[order[j]];
      for (std::size_t j = s; j < t; ++j) one(static_cast<std::size_t>(order[j]), block[j - s]);
    }
  });
}

// Sorts radius answers by (distance², index).
inline void sort_found(std::vector<WithinRadius::Entry>& found) {
  if (found.size() < 32) {  // insertion sort: most radius answers are short
    for (std::size_t i = 1; i < found.size(); ++i) {
      const auto e = found[i];
      std::size_t j = i;
      for (; j > 0 && e < found[j - 1]; --j) found[j] = found[j - 1];
      found[j] = e;
    }
  } else {
    std::sort(found.begin(), found.end());
  }
}

// Batched radius answers in query order. find_chunk(b, e, emit) answers the queries at
// positions [b, e) of the processing order `order` (empty: 0 .. n - 1) and calls emit(found)
// once per position, in order, with that query's answers in any order (sorted here). Fixed
// chunks gather answers locally; a prefix sum over per-query counts then places them, so the
// layout never depends on the thread count.
template <typename FindChunk>
RadiusResult gather_radius_chunks(std::size_t n, const std::vector<std::uint32_t>& order,
                                  const FindChunk& find_chunk) {
  const auto query_at = [&](std::size_t j) {
    return order.empty() ? j : static_cast<std::size_t>(order[j]);
  };
  const std::size_t chunks = (n + kQueryChunk - 1) / kQueryChunk;
  std::vector<std::vector<WithinRadius::Entry>> gathered(chunks);
  RadiusResult result;
  result.offsets.assign(n + 1, 0);
  parallel_chunks(chunks, 1, [&](std::size_t cb, std::size_t ce) {
    for (std::size_t c = cb; c < ce; ++c) {
      auto& out = gathered[c];
      const std::size_t b = c * kQueryChunk, e = std::min(n, b + kQueryChunk);
      std::size_t j = b;
      find_chunk(b, e, [&](std::vector<WithinRadius::Entry>& found) {
        sort_found(found);
        if (out.empty()) out.reserve(found.size() * (e - b) + 64);  // guess from the first
        result.offsets[query_at(j++) + 1] = found.size();
        out.insert(out.end(), found.begin(), found.end());
      });
    }
  });
  for (std::size_t q = 0; q < n; ++q) result.offsets[q + 1] += result.offsets[q];
  result.indices.resize(result.offsets[n]);
  result.distances.resize(result.offsets[n]);
  parallel_chunks(chunks, 1, [&](std::size_t cb, std::size_t ce) {
    for (std::size_t c = cb; c < ce; ++c) {
      const WithinRadius::Entry* e = gathered[c].data();
      for (std::size_t j = c * kQueryChunk; j < std::min(n, (c + 1) * kQueryChunk); ++j) {
        const std::size_t q = query_at(j);
        for (std::uint64_t slot = result.offsets[q]; slot < result.offsets[q + 1]; ++slot, ++e) {
          result.indices[slot] = e->index();
          result.distances[slot] = std::sqrt(e->d2());
        }
      }
      std::vector<WithinRadius::Entry>().swap(gathered[c]);
    }
  });
  return result;
}

// The same with one query at a time: find(q, point, found) appends query q's answers.
template <typename Find>
RadiusResult gather_radius(std::span<const Vec3> queries, const std::vector<std::uint32_t>& order,
                           const Find& find) {
  return gather_radius_chunks(
      queries.size(), order, [&](std::size_t b, std::size_t e, const auto& emit) {
        std::vector<WithinRadius::Entry> found;
        Vec3 block[kQueryChunk];  // see for_each_query
        for (std::size_t j = b; j < e; ++j) block[j - b] = queries[order.empty() ? j : order[j]];
        for (std::size_t j = b; j < e; ++j) {
          found.clear();
          find(order.empty() ? j : static_cast<std::size_t>(order[j]), block[j - b], found);
          emit(found);
        }
      });
}

inline KnnResult make_knn_result(std::size_t queries, int k) {
  KnnResult result;
  result.queries = queries;
  result.k = k;
  result.indices.resize(queries * static_cast<std::size_t>(k));
  result.distances.resize(queries * static_cast<std::size_t>(k));
  return result;
}

// Runs a result set over candidates and writes the k nearest of one query, nearest first,
// as Euclidean distances. scan(set) offers candidates to `set`.
template <typename Scan>
void nearest_k(int k, std::uint32_t* indices, float* distances, const Scan& scan) {
  if (k == 1) {
    NearestOne one;
    scan(one);
    indices[0] = one.index;
    distances[0] = one.d2;
  } else if (k <= kSortedMaxK) {
    NearestSorted sorted(distances, indices, k);
    scan(sorted);
  } else {
    NearestHeap heap(k);
    scan(heap);
    heap.finish(distances, indices);
  }
  for (int j = 0; j < k; ++j) distances[j] = std::sqrt(distances[j]);
}

}  // namespace splitray::detail

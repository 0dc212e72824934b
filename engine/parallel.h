#pragma once
// The engine's only oneTBB user. Loops run in the caller's task arena (the World's), so the thread
// count is set in exactly one place. Contracts (STYLE.md, deterministic parallelism):
//  - parallel_for bodies write only slots owned by their index;
//  - block_sum adds fixed-size blocks (size independent of the thread count) and combines the block
//    partials serially in block order, so floating sums are bitwise identical for any thread count.
#include <cstddef>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

namespace dem {

inline constexpr std::size_t default_grain = 256;

/// Runs body(i) for i in [0, n). Bodies must write only to slots owned by i.
template <class Body>
void parallel_for(std::size_t n, const Body& body, std::size_t grain = default_grain) {
  if (n <= grain) {  // one chunk anyway: skip the task machinery (small islands call this a lot)
    for (std::size_t i = 0; i < n; ++i) body(i);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) body(i);
  });
}

inline constexpr std::size_t sum_block_size = 1024;

/// Deterministic sum of value(i) for i in [0, n); T is any type with + and a zero from T{}.
template <class T, class Value>
T block_sum(std::size_t n, const Value& value, T zero = T{}) {
  const std::size_t block_count = (n + sum_block_size - 1) / sum_block_size;
  if (block_count <= 1) {  // the same additions in the same order as the one block below
    T s = zero;
    for (std::size_t i = 0; i < n; ++i) s = s + value(i);
    return zero + s;
  }
  std::vector<T> partial(block_count, zero);
  parallel_for(
      block_count,
      [&](std::size_t b) {
        const std::size_t end = std::min(n, (b + 1) * sum_block_size);
        T s = zero;
        for (std::size_t i = b * sum_block_size; i < end; ++i) s = s + value(i);
        partial[b] = s;
      },
      1);
  T total = zero;
  for (const T& p : partial) total = total + p;
  return total;
}

/// True when pred(i) holds for some i in [0, n). Logical OR is order-free, so any reduction is exact.
template <class Pred>
bool parallel_any(std::size_t n, const Pred& pred, std::size_t grain = default_grain) {
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, n, grain), false,
      [&](const tbb::blocked_range<std::size_t>& r, bool found) {
        for (std::size_t i = r.begin(); i != r.end() && !found; ++i) found = pred(i);
        return found;
      },
      [](bool a, bool b) { return a || b; });
}

/// Exclusive prefix sum of counts into offsets (size n + 1); serial, the counts are integers.
template <class Index>
void exclusive_scan(const std::vector<Index>& counts, std::vector<Index>& offsets) {
  offsets.resize(counts.size() + 1);
  offsets[0] = 0;
  for (std::size_t i = 0; i < counts.size(); ++i) offsets[i + 1] = offsets[i] + counts[i];
}

}  // namespace dem

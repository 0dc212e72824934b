#pragma once
// The engine's parallel helpers, over the project's one backend (broadphase/parallel.h: oneTBB, or
// std::threads in the ThreadSanitizer build). Loops run in the caller's TaskArena (the World's), so the
// thread count is set in exactly one place. Contracts (docs/design.md, Determinism):
//  - parallel_for bodies write only slots owned by their index;
//  - block_sum adds fixed-size blocks (size independent of the thread count) and combines the block
//    partials serially in block order, so floating sums are bitwise identical for any thread count;
//  - parallel_any and exact_reduce combine with exact, order-free operations;
//  - PerThread is scratch, or integer counters summed in any order; never floating sums.
#include <cstddef>
#include <vector>

#include "broadphase/parallel.h"

#if DEM_PARALLEL_STD_THREAD
#include <map>
#include <mutex>
#include <thread>
#else
#include <tbb/enumerable_thread_specific.h>
#endif

namespace dem {

using broadphase::TaskArena;
using broadphase::exact_reduce;
using broadphase::isolated;

inline constexpr std::size_t default_grain = 256;

/// Runs body(i) for i in [0, n). Bodies must write only to slots owned by i.
template <class Body>
void parallel_for(std::size_t n, const Body& body, std::size_t grain = default_grain) {
  if (n <= grain) {  // one chunk anyway: skip the task machinery (small islands call this a lot)
    for (std::size_t i = 0; i < n; ++i) body(i);
    return;
  }
  broadphase::parallel_ranges(n, grain, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i != end; ++i) body(i);
  });
}

/// Runs body(begin, end) over chunks that cover [0, n), as parallel_for splits it: for loops that
/// keep scratch across the indices of a chunk. Bodies must write only to slots owned by their indices.
template <class Body>
void parallel_chunks(std::size_t n, const Body& body, std::size_t grain = default_grain) {
  if (n <= grain) {
    if (n > 0) body(std::size_t{0}, n);
    return;
  }
  broadphase::parallel_ranges(n, grain, body);
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
  return exact_reduce(
      n, grain, false,
      [&](std::size_t begin, std::size_t end, bool found) {
        for (std::size_t i = begin; i != end && !found; ++i) found = pred(i);
        return found;
      },
      [](bool a, bool b) { return a || b; });
}

/// One T per thread that calls local(), each a copy of the exemplar when first asked for. For scratch
/// and for integer counters summed afterwards (for_each, outside parallel loops) in any order.
template <class T>
class PerThread {
 public:
  explicit PerThread(const T& exemplar = T{}) : slots_(exemplar) {}
  T& local() { return slots_.local(); }
  /// Calls f(t) on every T made so far, in no particular order.
  template <class F>
  void for_each(const F& f) {
    for (T& t : slots_) f(t);
  }

 private:
#if DEM_PARALLEL_STD_THREAD
  class Slots {
   public:
    explicit Slots(const T& exemplar) : exemplar_(exemplar) {}
    T& local() {
      const std::lock_guard<std::mutex> lock(mutex_);
      return slots_.try_emplace(std::this_thread::get_id(), exemplar_).first->second;
    }
    struct Iterator {
      typename std::map<std::thread::id, T>::iterator at;
      T& operator*() const { return at->second; }
      Iterator& operator++() { return ++at, *this; }
      bool operator!=(const Iterator& other) const { return at != other.at; }
    };
    Iterator begin() { return {slots_.begin()}; }
    Iterator end() { return {slots_.end()}; }

   private:
    std::mutex mutex_;
    T exemplar_;
    std::map<std::thread::id, T> slots_;  // nodes never move: references from local() stay valid
  };
  Slots slots_;
#else
  tbb::enumerable_thread_specific<T> slots_;
#endif
};

/// Exclusive prefix sum of counts into offsets (size n + 1); serial, the counts are integers.
template <class Index>
void exclusive_scan(const std::vector<Index>& counts, std::vector<Index>& offsets) {
  offsets.resize(counts.size() + 1);
  offsets[0] = 0;
  for (std::size_t i = 0; i < counts.size(); ++i) offsets[i + 1] = offsets[i] + counts[i];
}

}  // namespace dem

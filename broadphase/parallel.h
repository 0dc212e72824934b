#pragma once
// Small oneTBB helpers shared by the broadphase implementations (STYLE.md, "Deterministic parallelism").
// Reads and writes only what the caller passes. Threading: runs inside the caller's task arena; every
// helper gives the same result for every thread count (bodies write only the slots they own, and the scan
// is over integers, split into blocks whose size ignores the thread count).
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

namespace dem::broadphase::detail {

/// Calls body(begin, end) on disjoint sub-ranges covering [0, n), in parallel. The body must write only
/// slots owned by indices of its own sub-range.
template <class Body>
void parallel_ranges(std::size_t n, std::size_t grain, const Body& body) {
  if (n == 0) return;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, grain),
                    [&](const tbb::blocked_range<std::size_t>& r) { body(r.begin(), r.end()); });
}

/// Replaces values by their inclusive prefix sums and returns the total (64-bit, so the caller can see
/// that it overflowed 32 bits). Blocks of fixed size: sum each block in parallel, scan the block sums
/// serially, then add the block offsets in parallel. `block_sums` is scratch, reused across calls.
inline std::uint64_t inclusive_scan_in_place(std::span<std::uint32_t> values, std::vector<std::uint64_t>& block_sums) {
  constexpr std::size_t block = 16384;
  const std::size_t n = values.size();
  const std::size_t block_count = (n + block - 1) / block;
  block_sums.resize(block_count + 1);
  parallel_ranges(block_count, 1, [&](std::size_t b0, std::size_t b1) {
    for (std::size_t b = b0; b < b1; ++b) {
      std::uint64_t sum = 0;
      for (std::size_t i = b * block; i < std::min(n, (b + 1) * block); ++i) sum += values[i];
      block_sums[b] = sum;
    }
  });
  std::uint64_t running = 0;
  for (std::size_t b = 0; b < block_count; ++b) {
    const std::uint64_t sum = block_sums[b];
    block_sums[b] = running;
    running += sum;
  }
  parallel_ranges(block_count, 1, [&](std::size_t b0, std::size_t b1) {
    for (std::size_t b = b0; b < b1; ++b) {
      std::uint64_t sum = block_sums[b];
      for (std::size_t i = b * block; i < std::min(n, (b + 1) * block); ++i) {
        sum += values[i];
        values[i] = static_cast<std::uint32_t>(sum);
      }
    }
  });
  return running;
}

}  // namespace dem::broadphase::detail

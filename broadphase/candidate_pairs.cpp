// Structural check of CandidatePairs (see candidate_pairs.h for the invariants).
// Reads: one CandidatePairs. Writes: nothing. Threading: serial, no shared state; safe to call concurrently.
#include "broadphase/candidate_pairs.h"

namespace dem::broadphase {

// Checks everything that can be checked without positions and radii: the CSR shape, and that each row
// holds partners j > i, below n, strictly ascending (so each pair appears once).
bool is_valid(const CandidatePairs& pairs, std::size_t n) {
  const auto& start = pairs.row_start;
  if (start.size() != n + 1 || start[0] != 0 || start[n] != pairs.partner.size()) return false;
  for (std::size_t i = 0; i < n; ++i) {
    if (start[i] > start[i + 1]) return false;
    std::uint64_t previous = i;  // partners must exceed i, then each other
    for (std::size_t k = start[i]; k < start[i + 1]; ++k) {
      const std::uint64_t j = pairs.partner[k];
      if (j <= previous || j >= n) return false;
      previous = j;
    }
  }
  return true;
}

}  // namespace dem::broadphase

#pragma once
// Candidate pairs: the one output type of every broadphase, and the one predicate they all share.
//
// Invariants (checked by `is_valid`):
//  - row_start has n + 1 entries, row_start[0] = 0, non-decreasing, row_start[n] = partner.size();
//  - row i lists every j > i with is_candidate(i, j), ascending, each once.
// Indices are storage slots of the caller's arrays (0 .. n-1).
#include <Eigen/Core>
#include <cstdint>
#include <span>
#include <vector>

namespace dem::broadphase {

using Vec3 = Eigen::Vector3d;

struct CandidatePairs {
  std::vector<std::uint32_t> row_start{0};  // CSR offsets, size n + 1
  std::vector<std::uint32_t> partner;       // partners j > i of row i, ascending

  std::size_t row_count() const { return row_start.size() - 1; }
  std::size_t pair_count() const { return partner.size(); }
};

/// The candidate predicate all implementations evaluate, bit for bit the same way:
/// |x_i - x_j|^2 <= (r_i + r_j + skin)^2.
inline bool is_candidate(const Vec3& xi, double ri, const Vec3& xj, double rj, double skin) {
  const double reach = ri + rj + skin;
  return (xi - xj).squaredNorm() <= reach * reach;
}

/// True when `pairs` satisfies the invariants above for `n` particles.
bool is_valid(const CandidatePairs& pairs, std::size_t n);

}  // namespace dem::broadphase

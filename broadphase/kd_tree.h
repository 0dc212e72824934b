#pragma once
// k-d tree broadphase over nanoflann (wide size ranges, cross-checks of the grid).
// Reads: positions [m], radii [m], skin [m]. Writes: a CandidatePairs, and the tree it owns.
// Threading: the tree is built serially (nanoflann 1.4); the queries run as parallel loops
// (broadphase/parallel.h) in the caller's task arena, and the output is bit-identical for every thread
// count. One object must not run two calls at once.
#include "broadphase/candidate_pairs.h"

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace dem::broadphase {

/// Candidate pairs from a k-d tree: each particle i searches the radius r_i + r_max + skin (widened by a
/// hair so rounding never loses a pair), keeps j > i with is_candidate, and sorts its row.
class KdTreeBroadphase {
 public:
  /// An empty tree; each find_pairs builds it anew.
  KdTreeBroadphase();
  ~KdTreeBroadphase();
  KdTreeBroadphase(KdTreeBroadphase&&) noexcept;
  KdTreeBroadphase& operator=(KdTreeBroadphase&&) noexcept;

  /// Same contract as GridBroadphase::find_pairs: every pair i < j with is_candidate, CSR rows ascending.
  /// The tree refers to `positions` only during the call. nanoflann re-allocates its node pool on each
  /// build; the other buffers and `out` are reused. Limits: n < 2^32, fewer than 2^32 pairs.
  void find_pairs(std::span<const Vec3> positions, std::span<const double> radii, double skin, CandidatePairs& out);

  /// Heap bytes held by the tree and the scratch buffers.
  std::size_t memory_bytes() const;

 private:
  struct Tree;  // nanoflann stays out of this header (it is a private dependency)
  std::unique_ptr<Tree> tree_;
  std::vector<std::uint64_t> scan_scratch_;
};

}  // namespace dem::broadphase

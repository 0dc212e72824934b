#pragma once
// Skin tracker: decides when the candidate pairs must be rebuilt.
// Reads: positions [m] (and the reference copy taken at the last reset). Writes: the reference copy, in
// `reset` only. Threading: max reductions (broadphase/parallel.h) in the caller's task arena (max is
// exact, so the answer does not depend on the thread count); the const queries may run concurrently.
#include "broadphase/candidate_pairs.h"

#include <span>
#include <vector>

namespace dem::broadphase {

/// Candidate pairs built with skin s stay complete while no particle has moved more than s/2 since they
/// were built (two particles closing in cover at most s together).
class SkinTracker {
 public:
  /// Remembers `positions` as the state the current pairs were built from.
  void reset(std::span<const Vec3> positions);

  /// True when any particle has moved more than skin/2 [m] since the last reset (exactly skin/2 is still
  /// fine), when the particle count changed, when reset was never called, or when a displacement is not a
  /// number.
  bool needs_rebuild(std::span<const Vec3> positions, double skin) const;

  /// Largest distance any particle has moved since the last reset [m]; +infinity when the particle count
  /// changed or reset was never called; NaN when a displacement is not a number.
  double max_displacement(std::span<const Vec3> positions) const;

  /// Positions at the last reset (empty before the first), e.g. for checkpoints.
  std::span<const Vec3> reference() const { return reference_; }

  /// Heap bytes held by the reference copy.
  std::size_t memory_bytes() const { return reference_.capacity() * sizeof(Vec3); }

 private:
  double max_displacement_sq(std::span<const Vec3> positions) const;  // [m^2]

  std::vector<Vec3> reference_;  // positions at the last reset [m]
  bool has_reference_ = false;
};

}  // namespace dem::broadphase

#pragma once
// Brute-force broadphase: the O(n^2) test oracle.
// Reads: positions [m], radii [m], skin [m]. Writes: a CandidatePairs. Threading: serial, no shared
// state; distinct objects may run concurrently.
#include "broadphase/candidate_pairs.h"

#include <span>

namespace dem::broadphase {

/// Tests every pair i < j with is_candidate, in ascending order. Meant for tests up to ~2e4 particles.
class BruteForceBroadphase {
 public:
  /// Same contract as GridBroadphase::find_pairs.
  void find_pairs(std::span<const Vec3> positions, std::span<const double> radii, double skin, CandidatePairs& out);
};

}  // namespace dem::broadphase

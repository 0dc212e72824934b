// Brute-force broadphase (see brute_force.h).
// Reads: positions [m], radii [m], skin [m]. Writes: CandidatePairs. Threading: serial.
#include "broadphase/brute_force.h"

#include <cassert>

namespace dem::broadphase {

void BruteForceBroadphase::find_pairs(std::span<const Vec3> positions, std::span<const double> radii, double skin,
                                      CandidatePairs& out) {
  const std::size_t n = positions.size();
  assert(radii.size() == n);
  out.row_start.assign(1, 0);
  out.partner.clear();
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      if (is_candidate(positions[i], radii[i], positions[j], radii[j], skin)) {
        out.partner.push_back(static_cast<std::uint32_t>(j));
      }
    }
    out.row_start.push_back(static_cast<std::uint32_t>(out.partner.size()));
  }
}

}  // namespace dem::broadphase

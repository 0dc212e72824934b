#pragma once
// A broadphase for walls: for every particle, the walls it may touch before the lists go stale.
// Walls::filtered ones (lifter bars, resting containers, and planes and cylinders turning in place
// such as a mill's shell and end walls) enter a particle's list only when within `margin` of it at
// the build; every other wall (a turning box, a mesh) is listed for every movable particle. The lists
// stay valid while each particle's displacement since the build plus the filtered walls' largest
// travel (Walls::max_travel) is at most the margin: then no wall left out can have come into touch.
// The lists only skip tests that could not succeed, so contacts and results are the same as with no
// lists at all.
// Threading: build and the validity test are per particle, each writing only its own row, so the
// lists do not depend on the thread count.
#include <cstdint>
#include <vector>

#include "engine/state.h"
#include "engine/walls.h"

namespace dem {

class WallLists {
 public:
  /// Lists the walls within `margin` [m] of each particle of `s`, for the walls' current poses.
  /// Particles of inverse mass 0 get empty lists.
  void build(const State& s, const Walls& walls, Real margin);

  /// The lists of `parent` for its particles `members` (in that order), valid by the same test
  /// against the positions of parent's build: not valid when parent is not built.
  void select(const WallLists& parent, const std::vector<std::uint32_t>& members);

  /// Forgets the lists (particles added or removed: radii may differ slot by slot): valid() is false
  /// until the next build.
  void clear() { built_ = false; }

  /// True while the lists hold for `s` and the walls' current poses: the same particle count, and no
  /// particle moved further since the build than the margin less the filtered walls' travel.
  bool valid(const State& s, const Walls& walls) const;

  /// The walls listed for particle p, ascending: entries [row_start(p), row_start(p + 1)).
  std::uint32_t row_start(std::size_t p) const { return start_[p]; }
  std::uint16_t wall(std::uint32_t k) const { return wall_[k]; }
  /// The particles whose lists are not empty, ascending: the only ones that can touch a wall.
  const std::vector<std::uint32_t>& listed_particles() const { return listed_; }
  /// How many particles the lists were built for.
  std::size_t particle_count() const { return reference_.size(); }

  /// Heap bytes held.
  std::size_t memory_bytes() const;

 private:
  std::vector<std::uint32_t> start_;  // size n + 1
  std::vector<std::uint16_t> wall_;   // wall indices (types.h: max_walls fits 16 bits)
  std::vector<std::uint32_t> listed_;  // particles with a non-empty list, ascending
  std::vector<Eigen::Vector3f> reference_;  // positions at the build, in float (memory) [m]
  Real rounding_ = 0;                 // bound on the float copy's error in a displacement [m]
  Real time_ = 0;                     // the walls' time at the build [s]
  Real margin_ = 0;                   // [m]
  bool built_ = false;
};

}  // namespace dem

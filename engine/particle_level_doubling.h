#pragma once
// Step doubling with a level per particle on one island (docs/physics.md 6.10), for velocity Verlet.
// The island's round is cut into chunks, each one step of its coarsest member, or shorter where a few
// coarse members would make the many fine ones take long runs of steps (chunk_level_bound). A chunk is
// run twice by the multilevel stepper (multilevel_stepper.h), once with every member at its level and once
// with every level halved; each member's two results are compared over the chunk in the norm of
// step_control.h (a coarse member's error also counts how far its prediction missed, over its finer
// partners' budget), and each member's level is chosen from its own error. A member whose error is too
// large lowers its level, and its coarser touching partners with it, and the chunk is tried again for
// the members the failure touches (member_retry.h); when all pass, the island keeps the second trial
// (the finer one, merged with the retries) and each member the level its error asks for. So a fine
// member does not set the step of the whole island.
#include <cstdint>
#include <vector>

#include "engine/island_stepper.h"

namespace dem {

/// Collision anticipation with a level per particle (docs/physics.md 6.10): a candidate pair that is
/// apart and could close more than half its gap within a step of `chunk_level` (|v_rel| H + |a_rel|
/// H^2 / 2 > gap / 2, accelerations from the state's forces and `gravity`) caps both particles'
/// `levels` (full-trial levels) so that the step they are accepted at, one level finer, is at most
/// t_c / 8 of that contact (its own m* and normal stiffness); likewise a particle and a wall feature it
/// may reach (m* = m). Walls must be at the chunk's time.
void anticipate_per_pair(const State& state, const broadphase::CandidatePairs& candidates,
                         const MaterialTable& materials, const Walls& walls, const Vec3& gravity,
                         const DoublingSettings& settings, int chunk_level, std::vector<int>& levels);

/// The share of an island's movable members whose levels set its chunk: a few coarse members (a
/// sphere at the top of a bed with one contact) would make a chunk in which the many fine ones take
/// long runs of steps, over which some member nearly always fails, and every retry redoes those runs.
inline constexpr Real chunk_level_share = 0.97;

/// The level at most `highest` that chunk_level_share of the movable members (inv_mass not 0) of
/// `levels` are at or below; `highest` when none is movable.
int chunk_level_bound(const std::vector<int>& levels, const std::vector<Real>& inv_mass, int highest);

/// Advances `island` from tick `begin` to `end` of the interval starting at t0 [s] (one step of the
/// round's level, settings.level_max). `levels` holds each member's level: in, where it starts (clamped
/// to the round and lowered by collision anticipation and by its stability); out, the level of its
/// next step. `scratch`
/// holds the walls the trials set to their times and the two trials' groups.
void advance_island_per_particle(IslandState& island, const broadphase::CandidatePairs& candidates,
                                 const IslandPhysics& physics, const DoublingSettings& settings, IslandScratch& scratch,
                                 Real t0,
                                 std::int64_t begin, std::int64_t end, std::vector<int>& levels,
                                 DoublingCounters& counters);

}  // namespace dem

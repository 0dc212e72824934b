#pragma once
// Step doubling with a level per particle on one island (docs/physics.md 6.10), for velocity Verlet:
// the island's round is run twice by the multilevel stepper (multilevel_stepper.h), once with every
// member at its level and once with every level halved; each member's two results are compared over
// the round in the norm of step_control.h, and each member's level is chosen from its own error. A
// member whose error is too large lowers its level and the island's round is tried again; when all
// pass, the island keeps the second trial (the finer one) and each member the level its error asks for.
// A coarse member's error thus compares its predicted-and-booked path at two resolutions, and a fine
// member no longer sets the step of the whole island.
#include <cstdint>
#include <vector>

#include "engine/island_stepper.h"

namespace dem {

/// Advances `island` from tick `begin` to `end` of the interval starting at t0 [s] (one step of the
/// round's level, settings.level_max). `levels` holds each member's level: in, where it starts (clamped
/// to the round and lowered by collision anticipation); out, the level of its next step. `walls` is
/// scratch the trials set to their times.
void advance_island_per_particle(IslandState& island, const broadphase::CandidatePairs& candidates,
                                 const IslandPhysics& physics, const DoublingSettings& settings, Walls& walls, Real t0,
                                 std::int64_t begin, std::int64_t end, std::vector<int>& levels,
                                 DoublingCounters& counters);

}  // namespace dem

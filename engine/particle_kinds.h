#pragma once
// Kinds of particles: a small index per particle naming its material, inverse mass, inverse inertia
// and radius, the values a contact's law constants are made from (MaterialTable::law_constants).
// The persistent list's force loop (neighbour_forces) keys its reuse of those constants
// (LawConstantsMemo, materials.h) on the two kinds of a pair: one compare instead of seven. Serial;
// no effect on any result.
#include <cstdint>
#include <vector>

#include "engine/state.h"

namespace dem {

/// kind[p] for every particle p of `state`: two particles of one kind have the same material, inverse
/// mass, inverse inertia and radius, bit for bit (so -0 and +0 differ). Only the last four kinds seen
/// along the slots are recognised: where more than four are mixed in memory, alike particles may get
/// different kinds, which costs the memo a recomputation, never a wrong value.
void assign_particle_kinds(const State& state, std::vector<std::uint32_t>& kind);

}  // namespace dem

#pragma once
// Kinds of particles: a small index per particle naming its material, inverse mass, inverse inertia
// and radius, the values a contact's law constants are made from (MaterialTable::law_constants).
// The force loops key their reuse of those constants (LawConstantsMemo, materials.h) on the two kinds
// of a pair, one compare where the seven values took seven. Serial; no effect on any result.
#include <cstdint>
#include <vector>

#include "engine/state.h"

namespace dem {

/// kind[p] for every particle p of `state`: two particles of one kind have the same material, inverse
/// mass, inverse inertia and radius, bit for bit (so -0 and +0 differ). Particles alike but far apart
/// in memory among many kinds may get different kinds: that costs a recomputation, never a wrong value.
void assign_particle_kinds(const State& state, std::vector<std::uint32_t>& kind);

}  // namespace dem

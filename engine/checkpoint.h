#pragma once
// State hashing and checkpoints. The hash covers everything that determines the future of a run:
// particle kinematics in ParticleId order, contact keys and histories, and the clock. Checkpoints
// (World::save_checkpoint / load_checkpoint, defined in checkpoint.cpp) hold the full state, so a
// resumed run continues bit for bit.
#include <cstdint>

#include "engine/contacts.h"
#include "engine/scheduler.h"
#include "engine/state.h"

namespace dem {

/// 64-bit FNV-1a hash of the state's bits, independent of storage order.
std::uint64_t state_hash(const State& state, const PairContacts& pairs, const WallContacts& walls, const Clock& clock);

}  // namespace dem

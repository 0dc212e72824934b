#pragma once
// State hashing and checkpoints. The hash covers everything that determines the future of a run:
// particle kinematics in ParticleId order, contact keys and histories, and the clock. Checkpoints
// (World::save_checkpoint / load_checkpoint / start_from_checkpoint, defined in checkpoint.cpp) hold
// the full state, so a resumed run continues bit for bit.
#include <cstdint>

#include "engine/contacts.h"
#include "engine/scheduler.h"
#include "engine/state.h"

namespace dem {

/// What identifies the scene a checkpoint belongs to (scene.h computes both from the resolved scene):
/// `physics` hashes everything that decides a run's future, the integrator's settings included;
/// `body` the same without the integrator's and broadphase's settings (particles, materials,
/// contacts, walls, mill, model).
struct SceneHashes {
  std::uint64_t physics = 0;
  std::uint64_t body = 0;
};

/// 64-bit FNV-1a hash of the state's bits, independent of storage order.
std::uint64_t state_hash(const State& state, const PairContacts& pairs, const WallContacts& walls, const Clock& clock);

}  // namespace dem

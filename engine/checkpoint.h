#pragma once
// State hashing and checkpoints. The hash covers everything that determines the future of a run:
// particle kinematics in ParticleId order, contact keys and histories, and the clock. Checkpoints
// (World::save_checkpoint / load_checkpoint / start_from_checkpoint, defined in checkpoint.cpp) hold
// the full state, so a resumed run continues bit for bit.
#include <cstdint>
#include <string>

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

/// The first fields of a checkpoint: whose scene, which method, what time.
struct CheckpointHeader {
  SceneHashes hashes;
  Method method = Method::verlet;
  Real time = 0;  // [s]
};

/// Reads a checkpoint's header (the whole file is checked for damage first); throws
/// std::runtime_error naming the file when it is not a whole checkpoint of this format.
CheckpointHeader read_checkpoint_header(const std::string& path);

/// Why a run of a scene with `hashes` under `method` cannot start from a checkpoint with this header
/// (World::start_from_checkpoint): another body or another method; empty when it can.
std::string start_refusal(const CheckpointHeader& header, const SceneHashes& hashes, Method method);

/// 64-bit FNV-1a hash of the state's bits, independent of storage order.
std::uint64_t state_hash(const State& state, const PairContacts& pairs, const WallContacts& walls, const Clock& clock);

}  // namespace dem

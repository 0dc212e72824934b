#pragma once
// Per-particle state as a structure of arrays (docs/design.md, State). Hot arrays are one std::vector per
// field; a stage touches only those it needs. `id` holds the stable ParticleId of each slot and
// `index_of_id` the inverse map; both change only in functions of this file. Slots are in id order
// until permute() puts them in another (a fixed-step run may re-sort them in space).
#include <cstdint>
#include <limits>
#include <vector>

#include "engine/types.h"

namespace dem {

/// The index_of_id entry of a removed particle; its id is never given again.
inline constexpr ParticleIndex removed_slot = std::numeric_limits<ParticleIndex>::max();

struct State {
  std::vector<ParticleId> id;
  std::vector<Vec3> position;          // [m]
  std::vector<Vec3> velocity;          // [m/s]
  std::vector<Vec3> angular_velocity;  // [rad/s]; untouched when the scene has no rotation
  std::vector<Vec3> force;             // total force of the last evaluation [N]
  std::vector<Vec3> torque;            // total torque of the last evaluation [N m]
  std::vector<Real> radius;            // [m]
  std::vector<Real> inv_mass;          // [1/kg]; 0 for immovable particles
  std::vector<Real> inv_inertia;       // [1/(kg m^2)]
  std::vector<std::uint16_t> material;
  std::vector<std::int8_t> level;      // step = dt_base * 2^level; 0 under the fixed control
  std::vector<ParticleIndex> index_of_id;  // per id ever given: its slot, or removed_slot

  std::size_t size() const { return position.size(); }

  /// Appends one particle with the next free id and returns its slot.
  ParticleIndex add(const Vec3& x, const Vec3& v, const Vec3& w, Real r, Real inv_m, Real inv_i,
                    std::uint16_t mat);
  /// The same with a given id, which must be next_id() or larger (ids are never reused; the new
  /// particle, with the largest id, takes the last slot); the ids skipped map to removed_slot.
  /// Throws std::invalid_argument otherwise.
  ParticleIndex add(ParticleId given_id, const Vec3& x, const Vec3& v, const Vec3& w, Real r, Real inv_m,
                    Real inv_i, std::uint16_t mat);
  /// The id add() gives next: one past the largest id ever given.
  ParticleId next_id() const { return static_cast<ParticleId>(index_of_id.size()); }
  /// Reserves room for n particles in every array (a scene's particles, added one by one, would
  /// otherwise leave the arrays up to twice their size).
  void reserve(std::size_t n);
  /// Removes the particle in `slot`; later slots move down by one, so the others keep their order,
  /// and its id maps to removed_slot from then on.
  void remove(ParticleIndex slot);
  /// Moves the particle in slot order[q] to slot q for every q (`order` is a permutation of the
  /// slots), each array with it, and updates index_of_id: ids stay with their particles.
  void permute(const std::vector<std::uint32_t>& order);
  /// True when ids ascend along the slots (as add and remove keep them, until a permute).
  bool slots_follow_ids() const;
};

/// The particles `members` of `s` (slots), in that order, as a state of their own in `out` (which
/// keeps its storage); its index_of_id is left empty.
void select_particles(const State& s, const std::vector<ParticleIndex>& members, State& out);

/// Mass treated as infinite in momentum and energy audits (docs/physics.md 1.3: a 1e20 kg "wall" swamps
/// round-off of the real particles).
inline constexpr Real audit_mass_limit = 1e15;  // [kg]

inline bool is_audited(Real inv_mass) { return inv_mass * audit_mass_limit > 1; }

/// Whether particle p's position, velocity and spin are all finite (a run stops on the first that is not).
inline bool particle_is_finite(const State& s, std::size_t p) {
  return s.position[p].allFinite() && s.velocity[p].allFinite() && s.angular_velocity[p].allFinite();
}

}  // namespace dem

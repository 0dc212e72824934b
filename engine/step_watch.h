#pragma once
// What a step can get wrong without producing a NaN, watched after every fixed step (reliability,
// docs/physics.md 9.2): a contact deeper than the linear law describes, and a particle whose next step would
// carry it further than its own radius, so that it could step over a wall or another particle
// without any contact being seen (tunnelling). The World keeps the worst of each since the start;
// the divergence guard (engine/cli/energy_audit.h) stops a run on them.
// Threading: both are parallel max-reductions whose combine is exact and order-free (ties go to the
// smaller ids), so the answer is the same for any thread count.
#include "engine/contacts.h"
#include "engine/neighbour_contacts.h"
#include "engine/state.h"

namespace dem {

/// A particle (and for a pair, its partner) and a ratio describing it, with the time it was seen.
struct Worst {
  ParticleId particle = 0;
  ParticleId partner = 0;  // the second particle of a pair, else equal to particle
  Real value = 0;
  Real time = 0;  // [s]
  /// The larger value wins (a NaN over any number); equal values go to the smaller ids.
  static Worst worse(const Worst& a, const Worst& b);
};

/// The deepest pair or wall contact as a fraction of the smaller radius involved.
Worst deepest_contact(const State& s, const PairContacts& pairs, const WallContacts& walls);
/// The same from a persistent list, whose force loop kept each row's deepest contact
/// (NeighbourContacts::row_deepest): one value per particle to reduce instead of one per slot.
Worst deepest_contact(const State& s, const NeighbourContacts& pairs, const WallContacts& walls);

/// How many of its radii particle p's next step of h carries it at its present velocity: h |v| / R.
/// The fixed Verlet step books the largest over the particles in its closing kick (kick_and_check).
inline Worst step_travel(const State& s, std::size_t p, Real h) {
  return Worst{s.id[p], s.id[p], h * s.velocity[p].norm() / s.radius[p], 0};
}

}  // namespace dem

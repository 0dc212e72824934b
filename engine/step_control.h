#pragma once
// Step-doubling error control (docs/physics.md 6.4-6.7): the per-particle error norm comparing one full step
// with two half steps, the level decision it implies, and the Richardson-improved value. Pure
// functions; the island stepper (island_stepper.cpp) applies them to islands.
#include "engine/config.h"

namespace dem {

/// One particle's state after a trial: position, velocity, angular velocity.
struct TrialState {
  Vec3 position;          // [m]
  Vec3 velocity;          // [m/s]
  Vec3 angular_velocity;  // [rad/s]
};

/// Seed formula (3) as reconstructed, with the angular extension and a fixed velocity weight (engine choices):
///   E = (|x1 - x2| + w T |v1 - v2| + w R T |omega1 - omega2| - noise) / (|dX| + dx_min R h / T)
/// with one = the full step, two = two half steps, h the full step [s], dX the displacement over the
/// step [m], w the velocity weight, dx_min relative to the radius R, and T the reference time [s]
/// (T = h gives the seed's weighting exactly). With a fixed T (the World uses the sync interval) the
/// norm bounds the error per unit step: a velocity error made now is weighted by how far it carries
/// the particle over T, not over the (shrinking) step, and the floor for slow particles scales with
/// h, so summed over a trajectory the accepted errors add up to tolerance times the path, and the
/// global error is proportional to the tolerance. noise = 16 eps (|x2| + w T |v2| + w R T |omega2|):
/// differences within round-off of the state itself are not error (else a particle at rest could
/// never satisfy a tight tolerance at any step). Never negative.
Real step_error(const TrialState& one, const TrialState& two, const Vec3& displacement, Real h, Real reference_time,
                Real radius, Real velocity_weight, Real dx_min);

/// What to do after a trial at `level` with error `error` (docs/physics.md 6.6).
struct LevelDecision {
  bool accept;   // keep the step (always at level_min: then `forced`)
  bool forced;   // accepted only because level_min was reached
  int level;     // the level of the retry (rejected) or of the next step (accepted)
};

/// Order p of the stepper (verlet 2, exact 1), safety S, tolerance, and whether the current tick is
/// aligned with the doubled step (promotion only then, docs/physics.md 6.6).
LevelDecision decide_level(Real error, int level, int level_min, int level_max, int order, Real safety,
                           Real tolerance, bool aligned_for_promotion);

/// Richardson-improved value y* = (2^p y2 - y1) / (2^p - 1), of order p + 1.
Vec3 richardson(const Vec3& one, const Vec3& two, int order);

}  // namespace dem

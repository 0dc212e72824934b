#pragma once
// The exact (closed-form) stepper, docs/physics.md 5.3-5.7.
// One step of h: every pair or wall contact that can touch within the step is an "interaction";
// interactions are coloured so no two of a colour share a particle; then scheme (D), a symmetric
// (Strang) composition of exact pair flows:
//   for colours 1..C:  each interaction k:  remove the pair's free drift over h/2 after its exact flow
//                      over h/2          M_k = F_ij(-h/2) o P_k(h/2)
//   free flight of every particle over h (gravity included)                      F(h)
//   for colours C..1:  each interaction k:  the adjoint, exact flow after removing the drift
//                                           M_k* = P_k(h/2) o F_ij(-h/2)
// Exact at any h: free flight, a head-on pair, a contact with a flat wall (the drifts cancel:
// P(h/2) P(h/2) = P(h)), and whether an interaction's particles touch at all: onsets are found on the
// true 3-D path, so a near miss stays a miss. Approximations (docs/physics.md 5.7):
//  - several simultaneous contacts are coupled only through the splitting (second order in the
//    coupling, symplectic and time-reversible when undamped);
//  - an oblique pair, and a particle inside a cylinder wall, move in polar form about the partner (the
//    axis) while pushing: the distance follows the exact normal flow with the centrifugal term
//    |u_t|^2 / distance folded into its constant forcing, the tangential velocity keeps the angular
//    momentum and turns the normal. Energy and angular momentum are kept to round-off when undamped (the
//    centrifugal forcing is the discrete gradient between the stretch's ends) and the error converges
//    as h^2; gravity on one side only (an immovable partner, a cylinder wall) turns with the normal,
//    so energy is then kept to second order (symmetric stretches: bounded, no drift);
//  - a wall's velocity is frozen over h/2 at its contact point (the axis, for a cylinder), and so is
//    the normal of a flat feature (exact for planes and box faces, not for a solid box's edges);
//  - a contact the step's anticipation missed makes it redo the step with that contact included, up to
//    max_retries times; a contact still missed then is accepted and counted in `unresolved`.
// Friction and rolling resistance (exact_friction.h) are handled on flat wall features (planes, box
// faces): the wall flow is cut into sub-steps of at most half a radian of the normal oscillator, the
// normal channel is the exact normal flow, and over each sub-step the tangential and rolling channel
// is advanced exactly in its modes, split at the mode switches, under the sub-step's mean normal force
// (its exact normal impulse over the sub-step) and the lever arm at the mean overlap. That is exact for
// a contact whose normal force is steady (a ball rolling on a slope) and first order in the sub-step
// when the normal force varies within it (an impact).
// On pair contacts and cylinder walls the normal moves with the motion, so the flow is split instead:
// each pushing stretch is cut into pieces of at most a quarter radian of the normal oscillator (and at
// the release), and a piece is K(l/2) N(l) K(l/2), N the exact polar normal flow above and K the exact
// tangential and rolling channel (tangential_kick.h) with the geometry frozen and the normal force a line
// fitted to the piece's exact normal impulse and end values. Stated approximation: a splitting second
// order in the piece (measured: an oblique frictional 1 m/s collision at one contact per step within
// 7e-5 m/s of the same at 1/40 of a contact, tests/exact_pair_friction_test.cpp); a slide's friction
// impulse is mu times the exact normal impulse. Pair flows keep linear and angular momentum to
// round-off (equal and opposite impulses at one contact point, lever arms a_i + a_j = |x_i - x_j|); the
// contact law is contact_law.h's (switches on the spring force alone, the sliding spring at -F_t / k_t,
// springs released at the force-zero instant). Histories are kept by particle ids
// (exact_pair_history_key).
// Threading: interactions of one colour run in parallel, each writing only its two particles and
// its own slot; colours, pairs and sums are in fixed orders, so results do not depend on threads.
#include <algorithm>
#include <cstdint>
#include <map>
#include <vector>

#include "broadphase/candidate_pairs.h"
#include "engine/coloring.h"
#include "engine/contact_law.h"
#include "engine/exact_friction.h"
#include "engine/materials.h"
#include "engine/normal_flow.h"
#include "engine/propagator.h"
#include "engine/state.h"
#include "engine/step_watch.h"
#include "engine/walls.h"

namespace dem {

/// A mode switch of a wall contact found inside a step (docs/physics.md 2.5), with the particle's state at it.
struct ExactModeEvent {
  Real time = 0;                          // [s]
  ParticleIndex particle = 0;
  std::uint32_t wall = 0;
  std::uint8_t mode = 0;                  // ContactMode bits after the switch
  Vec3 position = Vec3::Zero();           // [m]
  Vec3 velocity = Vec3::Zero();           // [m/s]
  Vec3 angular_velocity = Vec3::Zero();   // [rad/s]
};

/// Tangential and rolling history of a contact, kept by the exact stepper between steps.
struct ExactHistoryRecord {
  std::uint64_t key;  // exact_history_key or exact_pair_history_key (ids, not slots)
  ContactHistory history;  // a pair's springs are those of the smaller id against the larger
  Real elastic = 0;        // energy in its tangential and rolling springs [J], for the World's books
};

/// Key of a wall contact's history record: the particle's stable id in the high 32 bits, so that a
/// copy of some particles under other slots (an island of step doubling) finds the same records, and
/// all records of one particle are adjacent; the wall and feature in the low bits.
inline std::uint64_t exact_history_key(ParticleId id, std::size_t wall, std::uint32_t feature) {
  return (std::uint64_t{id} << 32) | 0x80000000u | wall_feature_code(static_cast<std::uint32_t>(wall), feature);
}

/// Key of a pair contact's history record: the smaller id in the high 32 bits (so a particle's records
/// stay adjacent, as exact_history_key's), the larger in the low bits, below the wall keys' flag bit.
inline std::uint64_t exact_pair_history_key(ParticleId a, ParticleId b) {
  return (std::uint64_t{std::min(a, b)} << 32) | std::max(a, b);
}

/// True when a history key names a contact of particle `id` (as either partner of a pair).
inline bool exact_history_involves(std::uint64_t key, ParticleId id) {
  return (key >> 32) == id || ((key & 0x80000000u) == 0 && static_cast<ParticleId>(key) == id);
}

/// One pair or wall contact taking part in an exact step.
struct ExactInteraction {
  ParticleIndex i;
  ParticleIndex j;          // partner slot; unused for walls
  std::uint32_t wall;       // wall index, or no_wall for a particle pair
  std::uint32_t feature;    // wall feature
  NormalOscillator oscillator;
  Real stiffness;           // k [N/m], for the elastic energy
  Real effective_mass;      // m* [kg]
  Real dissipated;          // energy lost in this step [J]
  Real work;                // work the wall did on the particle in this step [J]; 0 for pairs
  const PropagatorCoefficients* half_step;  // table entry for h/2, or nullptr
  LawConstants constants;   // friction and rolling constants
  ContactHistory history;   // tangential and rolling springs and mode, carried through the step
  std::uint8_t event_count;  // mode switches found in this step (at most event_capacity kept)
  ExactModeEvent events[4];
  OverlapWatch watch;        // the deepest overlap reached inside this step (normal_flow.h)
  static constexpr std::uint8_t event_capacity = 4;

  static constexpr std::uint32_t no_wall = 0xffffffffu;
};

struct ExactWorkspace {
  std::vector<ExactInteraction> interactions;
  std::vector<std::uint32_t> count, offset;
  std::vector<ParticleIndex> edge_i, edge_j;
  ContactColoring coloring;
  std::vector<std::uint64_t> forced;             // interactions a retry must include (sorted keys)
  std::vector<Vec3> saved_position, saved_velocity, saved_angular_velocity;  // the state a retry restarts from
  std::uint64_t retries = 0;                       // steps redone because a contact was missed
  std::uint64_t unresolved = 0;  // steps accepted with a contact still missed after max_retries
  Real wall_work = 0;            // work done by moving walls on the particles, summed over steps [J]
  Worst deepest;                 // the deepest overlap inside the last step, over the smaller radius
  int max_retries = 8;           // redos of one step before a missed contact is accepted (and counted)
  // Coefficient table (docs/physics.md 5.2): one class per distinct (omega0, beta), built on demand for
  // the step h/2 in use; cleared when the step changes or the classes pass table_capacity (a wide
  // size distribution makes nearly every pair a class of its own).
  std::map<std::pair<std::uint64_t, std::uint64_t>, std::uint32_t> class_of;
  PropagatorTable table;
  Real table_step = 0;
  static constexpr std::size_t table_capacity = 1 << 16;
  // Friction and rolling resistance on wall contacts (exact_friction.h).
  RollingKind rolling = RollingKind::standard;  // rolling variant when the materials have rolling resistance
  std::vector<ExactHistoryRecord> history;      // contacts' histories (non-zero ones), sorted by key
  bool record_events = false;                   // append every mode switch to `events`
  std::vector<ExactModeEvent> events;           // mode switches in time order per step (if recorded)
};

struct ExactSettings {
  Separation separation;
  Vec3 gravity;
  int dimension;
  bool use_table = true;  // false: coefficients computed inline at every flow (for benchmarks)
  // Set by exact_step from the materials and ExactWorkspace::rolling (callers leave the defaults).
  bool friction = false;                     // tangential spring-slider on every contact
  RollingKind rolling = RollingKind::none;   // rolling resistance on every contact
};

/// A pair joins a step's interactions when its gap is within this many times the free relative
/// displacement over the step: the other contacts of the step change velocities too, and a contact
/// missed for a step starts the next one overlapped (energy from nothing). Pairs that then never
/// touch cost a free flight, which is exact.
inline constexpr Real anticipation_factor = 3;

/// Largest distance any particle can move in a free step of h [m]: |v| h + |g| h^2 / 2.
Real max_free_displacement(const State& state, const Vec3& gravity, Real h);

/// Advances every particle from t to t + h [s] with scheme (D); the walls are moved to the start of
/// each half sweep and left at t + h. `candidates` must hold every pair that can touch within the
/// step. Returns the energy the contacts dissipated [J]; adds the work of moving walls to work.wall_work
/// and counts a step accepted with a contact still missed in work.unresolved.
Real exact_step(State& state, Walls& walls, const MaterialTable& materials,
                const broadphase::CandidatePairs& candidates, const ExactSettings& settings, Real t, Real h,
                ExactWorkspace& work);

}  // namespace dem

#pragma once
// Step doubling on one island (docs/physics.md 6; docs/design.md, Time). An island is cut out of the
// World with its particles in ascending slot order (so ids, contact keys and row order are the
// World's), the candidate pairs among them and its contacts with their history. It steps with the
// kernels of the fixed control (Verlet kick-drift-forces-kick, or exact_step), three times per
// attempt: once over h and twice over h/2. The per-particle error of seed formula (3) decides:
// reject and retry at a finer level, or accept the two half steps and choose the next level.
// With method exact the island also carries its members' contact history (tangential and rolling
// springs, modes), which the exact stepper reads by particle id.
// Reads only its own copy; the World gathers islands from its state and scatters them back, so
// islands are independent and may run in any order on any thread.
#include <cmath>
#include <cstdint>
#include <vector>

#include "broadphase/candidate_pairs.h"
#include "engine/collision_spectra.h"
#include "engine/contacts.h"
#include "engine/exact_stepper.h"
#include "engine/forces.h"
#include "engine/materials.h"
#include "engine/member_retry.h"
#include "engine/multilevel_stepper.h"
#include "engine/state.h"
#include "engine/step_watch.h"
#include "engine/wall_lists.h"
#include "engine/walls.h"

namespace dem {

/// What changes when an island steps; copied for each trial, so a rejected step needs no undo.
struct IslandState {
  State state;
  PairContacts pairs;
  WallContacts walls;
  ContactAdjacency adjacency;
  std::vector<Real> excursion;  // per member: farthest distance from its start of the round [m]
  Real ended_dissipation = 0;   // by contacts that ended (Verlet) [J]
  Real exact_dissipated = 0;    // by the exact stepper's flows [J]
  Worst deepest;  // the deepest overlap of the accepted steps: inside them (exact), at their ends (Verlet), timed
  Real wall_work = 0;           // by moving walls on the island [J]
  // Contacts that ended (IslandPhysics::book_events), for the World's spectra; with a level per
  // particle (particle_level_doubling.h), those of the accepted trials.
  ContactEvents events;
  std::uint64_t unresolved = 0; // exact steps accepted with a contact still missed
  // The exact stepper's wall-contact springs and modes of the members (ExactWorkspace::history, keyed
  // by particle id, sorted), cut from the World's list with the island: each trial carries its own
  // copy, so a rejected trial or a redone round leaves no trace; the accepted one goes back to the World.
  std::vector<ExactHistoryRecord> exact_history;
};

/// The physics every island shares.
struct IslandPhysics {
  const MaterialTable* materials = nullptr;
  ForceKernels kernels;
  Vec3 gravity = Vec3::Zero();
  int dimension = 3;
  Method method = Method::verlet;
  Separation separation = Separation::force_zero;
  bool walls_move = false;
  DashpotVelocity dashpot;
  bool book_events = false;  // log ended contacts for collision spectra (the World books them)
  Real wall_margin = 0;      // margin of the wall lists of levels per particle [m] (MultilevelPhysics)
};

/// The error control of one round.
struct DoublingSettings {
  int level_min = 0;
  int level_max = 0;      // the round's level: no step is longer than the round
  Real dt_base = 0;       // [s]
  Real tolerance = 0;
  Real safety = 0.8;
  Real velocity_weight = 1;
  Real dx_min = 1e-3;     // relative to the radius
  Real reference_time = 0;  // [s] T of the error norm (step_control.h); 0: the step itself (the seed's)
  bool richardson = true;
  int contact_level = 0;  // a step at or below this level resolves any contact (Verlet anticipation)
};

/// Per-thread scratch.
struct IslandScratch {
  Walls walls;  // a copy: every island is at its own time
  ContactWorkspace contacts;
  ExactWorkspace exact;
  IslandState full, half;           // the two trials
  MultilevelGroup levels_full, levels_half;  // the two trials with a level per particle
  MemberRetry retry;                          // their retries of the members a rejection touches
  WallLists wall_lists;  // the island's at the start of a round, which the trials' levels select from
  std::vector<Vec3> origin;         // member positions at the start of the round [m]
};

/// Integer cost counters (sums of integers: the same for any order of islands).
struct DoublingCounters {
  std::uint64_t accepted = 0, rejected = 0, forced = 0, particle_steps = 0, force_evaluations = 0;
  std::uint64_t richardson = 0;          // accepted steps that took the improved value
  std::uint64_t member_retries = 0;      // tries that redid only part of an island (member_retry.h)
  std::vector<std::uint64_t> histogram;  // accepted particle-steps per level - level_min
  void add(const DoublingCounters& other);
};

/// Advances the island from tick `begin` to tick `end` of the finest step (level_min), where tick 0
/// is at time t0 [s], starting at `level`; returns the level its next step would take.
int advance_island(IslandState& island, const broadphase::CandidatePairs& candidates, const IslandPhysics& physics,
                   const DoublingSettings& settings, IslandScratch& scratch, Real t0, std::int64_t begin,
                   std::int64_t end, int level, DoublingCounters& counters);

/// True when particles a and b of `s` are apart and may close more than half their gap within h
/// (|v_a - v_b| h + |a_a - a_b| h^2 / 2 > gap / 2, accelerations from the forces and gravity); never
/// for two immovable particles.
bool pair_may_close(const State& s, std::size_t a, std::size_t b, const Vec3& gravity, Real h);
/// True when movable particle a of `s` may reach within h (the same closing distance, against the
/// wall's velocity there) a feature of wall w that it does not touch now. Walls at the state's time.
bool wall_may_close(const State& s, std::size_t a, const Walls& walls, std::size_t w, const Vec3& gravity, Real h);

/// The walls each particle of `s` may close on within a step h (wall_may_close), the same answers
/// for fewer tests: a filtered wall (Walls::filtered) farther from a particle than twice the most it
/// can close on any such wall within h (its own speed plus that of the fastest wall point at any
/// particle's centre, its acceleration) is passed over without its own closing speed. Where the
/// bound is not finite, every wall is tested.
class ClosingWalls {
 public:
  /// Walls at the state's time.
  ClosingWalls(const State& s, const Walls& walls, const Vec3& gravity);
  /// Calls visit(w) for the walls w that particle a may close on within h, in ascending order, while
  /// it returns true; returns false when it stopped.
  template <class Visit>
  bool for_each(std::size_t a, Real h, Visit&& visit) const {
    if (s_.inv_mass[a] == 0) return true;
    const Real reach = 2 * closing_bound(a, h);
    const bool bounded = std::isfinite(reach);
    for (std::size_t w = 0; w < walls_.count(); ++w)
      if ((!bounded || walls_.may_touch(w, s_.position[a], s_.radius[a], reach)) &&
          wall_may_close(s_, a, walls_, w, gravity_, h) && !visit(w))
        return false;
    return true;
  }

 private:
  /// At least wall_may_close's closing distance within h for particle a against any filtered wall
  /// [m] (the factor covers rounding).
  Real closing_bound(std::size_t a, Real h) const;

  const State& s_;
  const Walls& walls_;
  Vec3 gravity_;
  // At least the speed of a filtered wall's material at any particle's centre [m/s]; infinite when
  // a position is not finite.
  Real wall_speed_ = 0;
};

/// Merges the deepest contact of the island as it stands, at `time` [s] (an accepted step's end), into
/// island.deepest: the overlap audit sees inside a round, not only at its end.
void watch_deepest_contact(IslandState& island, Real time);

/// Largest level whose step keeps every approaching pair and wall of the island at least two steps
/// away from touching (|v_rel| h + |a_rel| h^2 / 2 <= gap / 2), or `contact_level`, whichever is
/// larger; never above `level`. Walls must be at the island's time.
int anticipation_level(const IslandState& island, const broadphase::CandidatePairs& candidates, const Walls& walls,
                       const Vec3& gravity, Real dt_base, int level, int contact_level);

}  // namespace dem

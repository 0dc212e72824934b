#pragma once
// Velocity Verlet with a level per particle inside one touching group (docs/design.md, Time;
// docs/physics.md 6.9). Particle p steps by H_p = dt_base * 2^level_p; a contact is
// evaluated at the finer of its two particles' levels, at that level's ticks, and its force is
// applied to both sides from the same evaluation:
//  - the finer side integrates it step by step;
//  - the coarser side, while its own step runs, stands in the evaluation as its prediction (start
//    position, velocity, spin and acceleration: x0 + v0 tau + a0 tau^2 / 2), and its step books the
//    force's impulse J = sum of h/2 (F_start + F_end) over the finer substeps, its first moment about
//    the step's end K, and the same for the torque (L, M);
//  - at its step's end: x = x0 + H v0 + H^2 g / 2 + K / m, v = v0 + H g + J / m, omega = omega0 + L / I.
// A force at tick t weighs h/2 on each substep it bounds, with moment (step end - t), so a particle
// whose partners all share its level makes exactly velocity Verlet's step, and the sums of J over
// both sides of every contact cancel: linear momentum balances to round-off whatever the levels.
// The velocity a contact law sees for a side is its mean over the substep just ended: the finer
// side's (x - x0) / H, the coarser side's from its prediction.
// The group owns a copy of its particles, its candidate pairs (which must stay valid while it
// advances: the caller's skin covers the motion) and its contacts, persistent per candidate pair and
// split by contact level (neighbour_contacts.h), and wall contacts split by particle level. Its loops
// write per row, slot or particle, in a fixed order, so results do not depend on thread count.
// Verlet only; the dashpot sees the half-step velocity (DashpotVelocity::predicted is not supported).
#include <cstdint>
#include <utility>
#include <vector>

#include "broadphase/candidate_pairs.h"
#include "engine/collision_spectra.h"
#include "engine/contacts.h"
#include "engine/forces.h"
#include "engine/neighbour_contacts.h"
#include "engine/state.h"
#include "engine/wall_lists.h"
#include "engine/walls.h"

namespace dem {

/// What every group of a run shares.
struct MultilevelPhysics {
  const MaterialTable* materials = nullptr;
  ForceKernels kernels;
  Vec3 gravity = Vec3::Zero();  // [m/s^2]
  int dimension = 3;
  Real dt_base = 0;   // the step of level 0 [s]
  int level_min = 0;  // the finest level: a tick is dt_base * 2^level_min
  bool walls_move = false;   // book the moving walls' work (wall_work)
  bool book_events = false;  // book ended contacts for collision spectra (spectra)
  // Wall lists (wall_lists.h) per particle level with this margin [m], so that a particle is tested
  // only against the walls near it; 0: against every wall. The contacts are the same either way.
  Real wall_margin = 0;
};

/// One step of a particle in MultilevelGroup::advance: where it started and how its partners saw
/// it, enough for another group to replay its path without integrating it.
struct StepRecord {
  Vec3 x0, v0, w0;     // start position, velocity, spin
  Vec3 a0, alpha0;     // start acceleration (with gravity) and angular acceleration
  Vec3 mean_velocity, mean_spin;  // over the step, as the contacts of its level saw them at its end
};

/// A particle that follows a recorded path instead of integrating its forces: its steps (as many as
/// its level takes in the advance, from MultilevelGroup::step_records) and where the path ends.
struct ReplayedPath {
  const StepRecord* steps = nullptr;  // nullptr: the particle is integrated as usual
  Vec3 end_position = Vec3::Zero(), end_velocity = Vec3::Zero(), end_spin = Vec3::Zero();
};

/// What one pair contact gave its two particles over an advance(), by the weights the steps booked:
/// the impulse on its row's side i (j got the negative), that impulse's first moment about the
/// advance's end, and the angular impulse on each side.
struct ContactImpulse {
  ParticleIndex i = 0, j = 0;  // group slots
  Vec3 impulse = Vec3::Zero();    // [N s]
  Vec3 moment = Vec3::Zero();     // [N s^2]
  Vec3 angular_i = Vec3::Zero(), angular_j = Vec3::Zero();  // [N m s]
};

class MultilevelGroup {
 public:
  /// An empty group, to be set by reset() (a scratch reused from chunk to chunk keeps its storage).
  MultilevelGroup() = default;
  /// Takes the group's particles (slots in id order), its candidate pairs and its walls (which it
  /// sets to each tick's time; they must outlive it) at `time` [s], sets the levels (one per particle, each at least physics.level_min) and evaluates every
  /// contact there without advancing its springs (h = 0), as a run's first evaluation does.
  MultilevelGroup(State state, broadphase::CandidatePairs candidates, Walls& walls,
                  const MultilevelPhysics& physics, Real time, const std::vector<int>& levels);
  /// The same with the group's contacts as they stand (with their history and the forces of their
  /// last evaluation, at `time`): `pairs` a compact list in key order, `wall_contacts` in key order,
  /// both indexed by the group's slots. Nothing is evaluated.
  MultilevelGroup(State state, broadphase::CandidatePairs candidates, Walls& walls,
                  const MultilevelPhysics& physics, Real time, const std::vector<int>& levels,
                  const PairContacts& pairs, const WallContacts& wall_contacts);

  /// What the second constructor does, into this group's storage: the per-particle and per-contact
  /// vectors keep their capacity, so a scratch group reset chunk after chunk allocates little.
  /// With `replay` (one per particle; copied, but the records its paths point into must outlive the
  /// group's next advance, the only one it replays), a particle with steps follows its path: its
  /// contacts with integrated partners are evaluated on it, it gets no wall contacts, and its own
  /// loads move nothing. Its contacts with other replayed particles must not be among the candidates.
  /// With `record`, the advances keep what a retry of them reads: step_records, ended_contacts and
  /// particle_wall_work (contact_impulses are kept either way).
  void reset(const State& state, const broadphase::CandidatePairs& candidates, Walls& walls,
             const MultilevelPhysics& physics, Real time, const std::vector<int>& levels, const PairContacts& pairs,
             const WallContacts& wall_contacts, const std::vector<ReplayedPath>* replay = nullptr,
             bool record = true);

  /// From the next reset on, each level's wall lists are selected from `lists` (built for other
  /// slots: this group's slot p is their particle (*slots)[p], or p without `slots`) rather than
  /// built anew; both must outlive the group's advances. nullptr: each level builds its own.
  void take_wall_lists_from(const WallLists* lists, const std::vector<ParticleIndex>* slots = nullptr) {
    source_lists_ = lists;
    source_slots_ = slots;
  }
  /// The wall lists given to take_wall_lists_from, if they index this group's own slots.
  const WallLists* wall_lists_source() const { return source_slots_ ? nullptr : source_lists_; }

  /// New levels (at a time every old and new step divides); contacts keep their history and last force.
  void set_levels(const std::vector<int>& levels);

  /// Advances by `ticks` finest steps; every particle's step must divide it.
  void advance(std::int64_t ticks);

  const State& state() const { return state_; }
  Real time() const { return time_; }
  int level(std::size_t p) const { return level_[p]; }
  /// Energy dissipated by contacts that ended [J].
  Real ended_dissipation() const { return ended_dissipation_; }
  /// The touching pair contacts, in key order, with row_start indexed.
  PairContacts pair_contacts() const;
  /// The same into `out`, which keeps its storage.
  void pair_contacts(PairContacts& out) const;
  /// The touching pairs (group slots, the row's first), by contact level and row: where only the
  /// partners matter, without pair_contacts()' copy and sort.
  std::vector<std::pair<ParticleIndex, ParticleIndex>> touching_pairs() const;
  /// The wall contacts, in key order (so by particle).
  WallContacts wall_contacts() const;
  /// The same into `out`, which keeps its storage.
  void wall_contacts(WallContacts& out) const;
  /// Work of the moving walls on the particles so far, each level's contacts times its step [J].
  Real wall_work() const { return wall_work_; }
  /// Per particle: the farthest it was, actual or predicted at any tick, from where it started [m].
  const std::vector<Real>& excursion() const { return excursion_; }
  /// Per particle: the largest distance between where its prediction put it at the end of one of its
  /// steps and where its booked forces took it [m]; 0 unless finer partners booked onto it.
  const std::vector<Real>& prediction_miss() const { return miss_; }
  /// Contacts that ended so far (physics.book_events).
  const ContactEvents& events() const { return events_; }
  /// Particle-steps taken so far: each integrated particle's steps, summed.
  std::uint64_t particle_steps() const { return particle_steps_; }
  /// Whether the last advance() recorded its steps: with `record`, when they average at most 32 per
  /// particle. Then integrated particle p's are step_records()[record_start(p) ..
  /// record_start(p + 1)], in time order (a replayed particle's are not written).
  bool steps_recorded() const { return steps_recorded_; }
  const std::vector<StepRecord>& step_records() const { return records_; }
  std::uint32_t record_start(std::size_t p) const { return record_start_[p]; }
  /// Every pair contact that touched at an evaluation of the last advance() (its start included),
  /// in the order they first touched.
  const std::vector<ContactImpulse>& contact_impulses() const { return impulses_; }
  /// The contacts that ended since the last reset, in the order they ended (with `record`).
  const std::vector<EndedContact>& ended_contacts() const { return ended_log_; }
  /// Per particle: the moving walls' work on it since the last reset (physics.walls_move, `record`) [J].
  const std::vector<Real>& particle_wall_work() const { return particle_wall_work_; }
  /// Heap bytes held (memory_usage.h: by capacity).
  std::size_t memory_bytes() const;

 private:
  /// The force or torque a particle receives at one tick: the plain sum (for the next step's start
  /// acceleration) and the sum weighted by h/2 of each contact's substeps.
  struct TickLoad {
    Vec3 force = Vec3::Zero(), weighted_force = Vec3::Zero();
    Vec3 torque = Vec3::Zero(), weighted_torque = Vec3::Zero();
  };
  /// One particle's current step.
  struct Step {
    std::int64_t start = 0;  // tick, from the start of advance()
    std::int64_t ticks = 1;
    Vec3 x0, v0, w0;        // start position, velocity, spin
    Vec3 a0, alpha0;        // start acceleration (with gravity) and angular acceleration
    Vec3 impulse = Vec3::Zero(), moment = Vec3::Zero();                  // J [N s], K [N s^2]
    Vec3 angular_impulse = Vec3::Zero(), angular_moment = Vec3::Zero();  // L [N m s], M [N m s^2]
  };

  void check_levels(const std::vector<int>& levels) const;
  /// Puts the contacts (compact, key order, group slots) into the lists of the current levels.
  void distribute(const PairContacts& pairs, const WallContacts& wall_contacts);
  /// Per-level lists are indexed from the group's finest level, so levels no member holds cost nothing.
  std::size_t level_index(int level) const { return static_cast<std::size_t>(level - base_level_); }
  Real step_of_index(std::size_t index) const;
  /// Ticks (steps of physics.level_min) in one step of level index `index`.
  std::int64_t ticks_of_index(std::size_t index) const {
    return std::int64_t{1} << (base_level_ - physics_.level_min + static_cast<int>(index));
  }
  Real tick_length() const;
  /// Evaluates the pair contacts of contact level index c and the wall contacts of the particles at
  /// that level, in view_, with springs advancing by h.
  void evaluate_level(std::size_t c, Real h);
  /// Adds what the contacts of level index c hold to load_ (moments stored by the last evaluation, or
  /// recomputed from the positions).
  /// Each contact's force also adds `weight` times itself to its impulse, and `weight * remaining`
  /// to its moment (remaining: from the evaluation to the advance's end [s]).
  void add_level_loads(std::size_t c, bool use_stored_normal, Real weight, Real remaining);
  bool replayed(ParticleIndex p) const { return !replayed_.empty() && replayed_[p].steps != nullptr; }
  /// Particle p's record of the step that starts at tick `start`.
  StepRecord& record(ParticleIndex p, std::int64_t start, std::int64_t ticks) {
    return records_[record_start_[p] + static_cast<std::size_t>(start / ticks)];
  }
  const StepRecord& replayed_step(ParticleIndex p, std::int64_t start, std::int64_t ticks) const {
    return replayed_[p].steps[start / ticks];
  }
  void add_load(ParticleIndex p, const Vec3& force, const Vec3& torque, Real weight);
  void clear_loads();
  /// Positions at the end of the steps of the particles at level index <= due, from their books (in
  /// state_ and view_).
  void finish_positions(std::size_t due);
  /// view_ positions at tick t of the coarser partners of the particles due there, as predicted.
  void set_view_positions(std::int64_t t, std::size_t due);
  /// view_ velocities and spins for the contacts of level index c at tick t.
  void set_view_motion(std::int64_t t, std::size_t c);
  /// After the evaluation at t: the due particles end their steps (and begin the next unless `last`),
  /// the others book the loads.
  void end_steps(std::int64_t t, std::size_t due, bool last);
  void begin_step(ParticleIndex p, std::int64_t t);

  MultilevelPhysics physics_;
  State state_;
  State view_;  // the state contacts are evaluated in: actual or predicted positions, mean velocities
  broadphase::CandidatePairs candidates_;
  Walls* walls_ = nullptr;
  Real time_ = 0;
  Real time0_ = 0;  // at construction or reset [s]
  std::int64_t tick_origin_ = 0;  // ticks since construction or reset at the start of the current advance
  std::vector<int> level_;
  int base_level_ = 0;  // the finest level of level_ (physics_.level_min when empty)
  std::vector<Real> level_step_;  // per level index: its step [s]
  Real tick_ = 0;                 // the step of physics_.level_min [s]
  bool rotation_ = false;
  ContactParts parts_;

  // Per contact level index: candidate pairs whose finer side is at that level, their persistent list
  // and the compact list it was last rebuilt from.
  std::vector<broadphase::CandidatePairs> level_candidates_;
  std::vector<NeighbourContacts> neighbours_;
  std::vector<PairContacts> rebuilt_from_;
  // Per particle level index: its members (group slots, ascending), those with wall contacts (the
  // integrated ones), their sub-state for the wall contacts and those contacts (particle = index
  // into the wall members).
  std::vector<std::vector<ParticleIndex>> members_;
  std::vector<std::vector<ParticleIndex>> wall_members_;
  std::vector<State> member_state_;
  std::vector<WallContacts> wall_contacts_;
  std::vector<std::vector<std::uint32_t>> wall_start_;
  std::vector<WallLists> wall_lists_;
  const WallLists* source_lists_ = nullptr;               // take_wall_lists_from
  const std::vector<ParticleIndex>* source_slots_ = nullptr;
  std::vector<ParticleIndex> source_members_;             // scratch of distribute()
  ContactWorkspace workspace_;

  // Per contact level index: the rows holding its candidate pairs, and the particles coarser than it
  // among their sides (the ones predicted when its contacts are evaluated).
  std::vector<std::vector<ParticleIndex>> rows_;
  std::vector<std::vector<ParticleIndex>> participants_;
  // Scratch of distribute().
  std::vector<PairContacts> compact_;
  std::vector<std::uint32_t> fill_, member_index_;
  std::vector<std::uint8_t> seen_;

  std::vector<Step> step_;
  std::vector<TickLoad> load_;                 // zero but for the particles in loaded_list_
  std::vector<std::uint8_t> loaded_;
  std::vector<ParticleIndex> loaded_list_;
  Real ended_dissipation_ = 0;
  Real wall_work_ = 0;
  std::vector<Real> excursion_;
  std::vector<Real> miss_;
  std::vector<Vec3> origin_;
  ContactEvents events_;
  std::uint64_t particle_steps_ = 0;
  std::vector<ReplayedPath> replayed_;  // empty: every particle integrated
  bool recording_ = true;
  bool steps_recorded_ = false;  // by the last advance
  std::int64_t advance_ticks_ = 0;      // of the advance() under way
  std::vector<StepRecord> records_;
  std::vector<std::uint32_t> record_start_;
  std::vector<ContactImpulse> impulses_;
  std::vector<std::vector<std::uint32_t>> impulse_of_;  // per contact level index and slot: into impulses_
  std::vector<EndedContact> ended_log_;
  std::vector<Real> particle_wall_work_;
};

}  // namespace dem

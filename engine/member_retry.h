#pragma once
// The retry of a rejected chunk with a level per particle (docs/physics.md 6.11): instead of the whole
// island, only the `live` members (those that failed, their touching partners, those whose level
// changed, and what earlier retries of the chunk redid) are integrated again, at their new levels,
// in both trials. Their other candidate partners, the border, replay the paths the first try gave
// them (MultilevelGroup's ReplayedPath), so the live members meet them where they were; each border
// particle then receives at the chunk's end what its live partners now gave it less what they gave
// it in the first try (impulse, its first moment about the chunk's end, angular impulse), so linear
// momentum balances to round-off. Everything else keeps the first try. The merged trials are read
// member by member, and the merged half trial is what the island keeps when every member passes.
// The first try's groups must stay unchanged while a retry is read: the border replays their records.
#include <cstdint>
#include <utility>
#include <vector>

#include "broadphase/candidate_pairs.h"
#include "engine/contacts.h"
#include "engine/multilevel_stepper.h"
#include "engine/state.h"
#include "engine/step_control.h"
#include "engine/walls.h"

namespace dem {

class MemberRetry {
 public:
  enum class Trial { full = 0, half = 1 };

  /// Forgets the last retry: every member reads the first try.
  void clear() { active_ = false; }
  bool active() const { return active_; }

  /// Redoes the chunk of `ticks` finest steps from `start` (the island's state, contacts `pairs` and
  /// `wall_contacts` at time `time`, slots in id order) for the members with live[q] != 0, at `levels`
  /// (full trial) and `halves` (half trial), against the first try `first_full` and `first_half`, whose
  /// levels the other members keep. `start` must stay unchanged (its ids at least) while this
  /// retry is read.
  void redo(const State& start, const PairContacts& pairs, const WallContacts& wall_contacts,
            const broadphase::CandidatePairs& candidates, Walls& walls, const MultilevelPhysics& physics, Real time,
            std::int64_t ticks, const std::vector<std::uint8_t>& live, const std::vector<int>& levels,
            const std::vector<int>& halves, const MultilevelGroup& first_full, const MultilevelGroup& first_half);

  /// Member q's end of a trial, merged.
  TrialState end(Trial trial, std::size_t q) const;
  /// Member q's prediction miss in the full trial (MultilevelGroup::prediction_miss), with a border
  /// member's correction added: its partners outside the retry saw it on its first path.
  Real miss(std::size_t q) const;
  /// The touching pairs (island slots) of the merged full trial.
  std::vector<std::pair<ParticleIndex, ParticleIndex>> touching_pairs() const;
  /// Particle-steps the last retry integrated (both trials).
  std::uint64_t particle_steps() const {
    return trial_[0].group.particle_steps() + trial_[1].group.particle_steps();
  }

  /// The merged half trial: its contacts (island slots, key order), the energy its ended contacts
  /// dissipated, the moving walls' work, its ended-contact events (appended to `out`) and each
  /// member's excursion (MultilevelGroup::excursion).
  void half_contacts(PairContacts& pairs, WallContacts& wall_contacts) const;
  Real half_ended_dissipation() const;
  Real half_wall_work() const;
  void half_events(ContactEvents& out) const;
  Real half_excursion(std::size_t q) const;

  std::size_t memory_bytes() const;

 private:
  static constexpr std::uint32_t outside = 0xffffffffu;
  /// One trial's retry: its group and the corrections of its border members (by group slot).
  struct TrialRetry {
    MultilevelGroup group;
    std::vector<ReplayedPath> replayed;
    std::vector<Vec3> shift, kick, spin_kick;  // position, velocity and spin corrections
    const MultilevelGroup* first = nullptr;
  };
  void run(TrialRetry& trial, const std::vector<int>& levels, const MultilevelGroup& first, Walls& walls,
           const MultilevelPhysics& physics, Real time, std::int64_t ticks);
  /// Whether an ended-contact key (pair or wall) names a live member.
  bool key_is_live(std::uint64_t key, bool wall) const;
  bool id_is_live(ParticleId id) const;

  bool active_ = false;
  const State* start_ = nullptr;
  std::vector<std::uint8_t> live_;
  std::vector<ParticleIndex> group_;
  std::vector<std::uint32_t> sub_of_;  // per island slot: its group slot, or outside
  State sub_state_;
  broadphase::CandidatePairs sub_candidates_;
  PairContacts sub_pairs_;
  WallContacts sub_walls_;
  std::vector<int> sub_levels_;
  TrialRetry trial_[2];  // by Trial
  const TrialRetry& of(Trial trial) const { return trial_[static_cast<int>(trial)]; }
};

}  // namespace dem

#pragma once
// The World owns everything a run needs and advances it one sync interval at a time.
// One sync interval (fixed control, velocity Verlet), top to bottom in world.cpp:
//   kick (v += h/2 a)  ->  drift (x += h v)  ->  walls to t + h
//   -> skin check, rebuild candidate pairs if any particle moved more than skin/2
//   -> update contacts (history inherited by key) -> contact forces -> gather per particle
//   -> kick (v += h/2 a) -> finite-state check
// All parallel loops run inside the World's own tbb::task_arena, so an embedding program keeps
// control of its own threads. Results are bitwise identical for any thread count.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <tbb/task_arena.h>

#include "broadphase/candidate_pairs.h"
#include "broadphase/grid.h"
#include "broadphase/kd_tree.h"
#include "broadphase/skin.h"
#include "engine/config.h"
#include "engine/contacts.h"
#include "engine/exact_stepper.h"
#include "engine/forces.h"
#include "engine/materials.h"
#include "engine/scheduler.h"
#include "engine/state.h"
#include "engine/walls.h"

namespace dem {

struct DoublingWork;

/// Outcome of advancing; anything but `ok` leaves the state inspectable and the run stopped.
enum class StepStatus { ok, non_finite };

struct Energies {
  Real kinetic = 0;     // translational [J]
  Real rotational = 0;  // [J]
  Real potential = 0;   // gravitational, relative to the origin [J]
  Real elastic = 0;     // stored in contact springs [J]
  Real total() const { return kinetic + rotational + potential + elastic; }
};

/// Energy audit since the start: what appeared from nowhere, against the energy in play.
struct EnergyBalance {
  Real error;  // (E - E0) + dissipated - work of the walls [J]; ~0 for a sound run
  Real scale;  // energy in play: kinetic, rotational and elastic at start, |dPE|, dissipated, |wall work| [J]
};

/// Cost counters; particle-steps and force evaluations count every trial and retry.
struct RunCounters {
  std::uint64_t sync_intervals = 0;
  std::uint64_t accepted_steps = 0;  // particle-steps accepted
  std::uint64_t rejected_steps = 0;
  std::uint64_t forced_steps = 0;
  std::uint64_t particle_steps = 0;
  std::uint64_t force_evaluations = 0;
  std::uint64_t pair_rebuilds = 0;
  std::uint64_t unresolved_contacts = 0;  // exact steps accepted with a contact missed after every retry
  // Step doubling only:
  std::uint64_t richardson_steps = 0;     // island steps that took the improved value
  std::uint64_t round_redos = 0;          // island rounds redone: a contact between islands or a skin overrun
  std::vector<std::uint64_t> level_histogram;  // accepted particle-steps per level - level_min
};

class World {
 public:
  /// Builds the world; throws std::invalid_argument on an inconsistent configuration.
  explicit World(const WorldConfig& config);
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  /// Advances every particle to the next sync time.
  StepStatus advance_sync_interval();
  /// Advances until the first sync time at or after t [s].
  StepStatus run_until(Real t);

  Real time() const { return scheduler_.time(clock_); }
  Real sync_interval() const { return scheduler_.sync_interval(); }
  const Clock& clock() const { return clock_; }
  int thread_count() const { return threads_; }
  /// The arena all engine loops run in (for observers and embedding programs).
  tbb::task_arena& arena() const { return *arena_; }

  const WorldConfig& config() const { return config_; }
  const State& state() const { return state_; }
  const MaterialTable& materials() const { return materials_; }
  const Walls& walls() const { return walls_; }
  const PairContacts& pair_contacts() const { return pairs_; }
  const WallContacts& wall_contacts() const { return wall_contacts_; }
  const RunCounters& counters() const { return counters_; }
  Real skin() const { return skin_; }
  bool has_rotation() const { return kernels_.uses_rotation; }

  /// Force and torque of the particles on each wall at the last evaluation (one pass over contacts).
  std::vector<WallLoad> wall_loads() const;
  /// The same for one wall.
  WallLoad wall_load(std::size_t w) const { return wall_loads().at(w); }
  Energies energies() const;
  /// Energy dissipated by contacts since the start (dashpots, sliding, rolling, released springs) [J].
  Real dissipated_energy() const;
  /// Work the moving walls have done on the particles since the start [J].
  Real wall_work() const { return wall_work_; }
  /// Energy conservation check: a step beyond the stability limit shows as a large positive error.
  EnergyBalance energy_balance() const;
  /// Total linear momentum of finite-mass particles [kg m/s].
  Vec3 linear_momentum() const;
  std::uint64_t state_hash() const;
  /// Checkpoint of the full state (particles, contacts with history, clock, counters, neighbour
  /// lists) in a binary file written atomically; `scene_hash` identifies the physics it belongs to.
  void save_checkpoint(const std::string& path, std::uint64_t scene_hash) const;
  /// Restores a checkpoint of a world built from the same scene; throws std::runtime_error when the
  /// file is not a checkpoint, is damaged, or belongs to other physics (another scene_hash).
  void load_checkpoint(const std::string& path, std::uint64_t scene_hash);
  /// The bytes save_checkpoint would write (to keep the last good state in memory).
  std::string checkpoint_bytes(std::uint64_t scene_hash) const;

  /// For divergence messages: a particle and a number describing it.
  struct Culprit {
    ParticleId particle = 0;
    ParticleId partner = 0;  // second particle of a pair (deepest overlap), else equal to particle
    Real value = 0;
  };
  /// The particle with the largest speed [m/s].
  Culprit fastest_particle() const;
  /// The deepest pair or wall overlap as a fraction of the smaller radius involved.
  Culprit deepest_overlap() const;

  /// Heap bytes held by particle, contact and broadphase arrays (capacities, scratch included).
  std::size_t memory_bytes() const;

 private:
  void add_particles();
  void evaluate_forces(Real h, bool force_rebuild);
  void rebuild_candidates();
  void step_exact(Real h);
  // Step doubling (world_doubling.cpp).
  void init_doubling();
  StepStatus advance_doubling_interval();
  int round_level(std::int64_t tick);
  void run_round(std::int64_t tick, int level);
  void find_round_islands(Real h);
  void run_islands(const std::vector<std::uint32_t>& which, std::int64_t tick, int level);
  bool find_conflicts();
  void finish_round();
  bool state_is_finite() const;

  WorldConfig config_;
  int threads_ = 1;
  std::unique_ptr<tbb::task_arena> arena_;
  State state_;
  MaterialTable materials_;
  Walls walls_;
  Scheduler scheduler_;
  Clock clock_;
  ForceKernels kernels_;
  Vec3 gravity_ = Vec3::Zero();
  Real skin_ = 0;

  broadphase::GridBroadphase grid_;
  broadphase::KdTreeBroadphase kd_tree_;
  broadphase::SkinTracker skin_tracker_;
  broadphase::CandidatePairs candidates_;

  PairContacts pairs_;
  WallContacts wall_contacts_;
  ContactAdjacency adjacency_;
  ContactWorkspace workspace_;
  RunCounters counters_;
  Real ended_dissipation_ = 0;  // dissipated by contacts that have ended [J]
  Real candidate_skin_ = 0;     // skin of the current candidate list [m] (the exact stepper widens it)
  ExactWorkspace exact_work_;
  Real wall_work_ = 0;          // work of the walls on the particles [J]
  bool walls_move_ = false;     // any wall with prescribed velocity
  Energies start_energies_;     // at construction, for the energy balance
  Real exact_dissipated_ = 0;   // energy the exact stepper's contacts dissipated [J]
  std::unique_ptr<DoublingWork> doubling_;  // step doubling's islands and scratch
};

}  // namespace dem

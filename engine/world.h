#pragma once
// The World owns everything a run needs and advances it one sync interval at a time.
// One sync interval (fixed control, velocity Verlet), top to bottom in world.cpp:
//   kick (v += h/2 a)  ->  drift (x += h v)  ->  walls to t + h
//   -> skin check, rebuild candidate pairs if any particle moved more than skin/2 (and with them the
//      persistent pair list, history inherited by key: neighbour_contacts.h), first re-sorting the
//      particles in memory by spatial bins when broadphase.sort_interval steps have passed
//   -> pair forces slot by slot (contacts start and end in place) -> wall contacts and forces
//   -> gather per particle -> kick (v += h/2 a) -> finite-state check
// All parallel loops run inside the World's own TaskArena (engine/parallel.h: oneTBB, or std::threads
// in the ThreadSanitizer build), so an embedding program keeps control of its own threads. Results
// are bitwise identical for any thread count.
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "broadphase/candidate_pairs.h"
#include "broadphase/grid.h"
#include "broadphase/kd_tree.h"
#include "broadphase/skin.h"
#include "engine/checkpoint.h"
#include "engine/collision_spectra.h"
#include "engine/config.h"
#include "engine/contacts.h"
#include "engine/exact_stepper.h"
#include "engine/forces.h"
#include "engine/materials.h"
#include "engine/memory_usage.h"
#include "engine/neighbour_contacts.h"
#include "engine/parallel.h"
#include "engine/scheduler.h"
#include "engine/state.h"
#include "engine/step_watch.h"
#include "engine/walls.h"

namespace dem {

struct DoublingWork;
struct CheckpointContents;
struct Scene;

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
  std::uint64_t member_retries = 0;       // levels per particle: tries that redid only part of an island
  std::vector<std::uint64_t> level_histogram;  // accepted particle-steps per level - level_min
};

/// One contact's force at the last evaluation, as an embedding program reads it (World::contact_forces).
struct ContactForce {
  ParticleId particle = 0;  ///< pairs: the smaller id; walls: the particle
  ParticleId partner = 0;   ///< pairs: the larger id; walls: equal to `particle`
  int wall = -1;            ///< wall index (World::walls()) for a wall contact; -1 for a pair
  Vec3 force = Vec3::Zero();  ///< on `particle`; the partner or the wall gets the negative [N]
  Vec3 point = Vec3::Zero();  ///< contact point: mid-overlap on the line of centres or the wall normal [m]
  Real overlap = 0;           ///< [m]
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
  /// The arena all engine loops run in (for embedding programs; in the oneTBB build, native() is the
  /// tbb::task_arena, for observers).
  TaskArena& arena() const { return *arena_; }

  /// The configuration the world was built from, each particle with the id it got, and every
  /// particle add_particle added since.
  const WorldConfig& config() const { return config_; }
  const State& state() const { return state_; }
  const MaterialTable& materials() const { return materials_; }
  const Walls& walls() const { return walls_; }
  /// The pair contacts of the last force evaluation, compact and in key order.
  const PairContacts& pair_contacts() const {
    sync_pair_contacts();
    return pairs_;
  }
  const WallContacts& wall_contacts() const { return wall_contacts_; }
  const RunCounters& counters() const { return counters_; }
  /// Collision energy spectra of the contacts ended so far; null unless config.collision_spectra and
  /// velocity Verlet (either control; the exact stepper keeps no per-contact books).
  const CollisionSpectra* collision_spectra() const { return spectra_.get(); }
  /// The scene's neighbour skin, or its default (0.1 smallest radius) [m].
  Real skin() const { return skin_; }
  /// True when the run chooses the skin of each candidate list from the speeds (fixed-step Verlet
  /// without a skin in the scene), between skin() and 10 skin().
  bool skin_is_chosen() const { return adaptive_skin_; }
  /// The skin of the current candidate list [m].
  Real candidate_skin() const { return candidate_skin_; }
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
  /// lists) in a binary file written atomically; `hashes` identify the scene it belongs to.
  void save_checkpoint(const std::string& path, const SceneHashes& hashes) const;
  /// Restores a checkpoint of a world built from the same scene, to go on bit for bit; throws
  /// std::runtime_error when the file is not a checkpoint, is damaged, or belongs to other physics or
  /// integrator settings (another hashes.physics).
  void load_checkpoint(const std::string& path, const SceneHashes& hashes);
  /// Starts this world from a checkpoint of the same particles, materials, walls and model under its
  /// own integrator settings (another control, step, tolerance or skin; the same method): the
  /// particles, contacts with their history, energy books and spectra are the checkpoint's, time goes
  /// on from the checkpoint's, and the clock, counters and levels start as a new run's. Under the
  /// checkpoint's own settings it need not follow that run bit for bit: its times are rounded
  /// otherwise, which moving walls see.
  /// Throws std::runtime_error like load_checkpoint, for another hashes.body or another method.
  void start_from_checkpoint(const std::string& path, const SceneHashes& hashes);
  /// The bytes save_checkpoint would write (to keep the last good state in memory).
  std::string checkpoint_bytes(const SceneHashes& hashes) const;

  /// For divergence messages: a particle (and partner) and a number describing it (step_watch.h).
  using Culprit = Worst;
  /// The particle with the largest speed [m/s].
  Culprit fastest_particle() const;
  /// The deepest pair or wall overlap now, as a fraction of the smaller radius involved.
  Culprit deepest_overlap() const;
  /// The deepest overlap since the start (or the resume), with the time it was seen: after every
  /// step under the fixed control; under doubling at every round's end and after every accepted step
  /// (every accepted chunk with a level per particle) inside the islands.
  const Culprit& deepest_overlap_seen() const { return deepest_seen_; }
  /// The largest h |v| / R after any velocity Verlet step of the fixed control since the start: how
  /// many radii a particle's next step would carry it. Beyond 1 a contact can be stepped over (the
  /// exact stepper and step doubling find contacts on the path; for them this stays 0).
  const Culprit& longest_step_travel_seen() const { return travel_seen_; }

  /// Heap bytes held by particle, contact, broadphase and stepper arrays, by capacity (what is
  /// allocated, not what is in use), scratch and per-thread workspaces included; walls and
  /// materials (not per particle) are left out. The sum of memory_breakdown().
  std::size_t memory_bytes() const;
  /// The same bytes by container group, in a fixed order (world_memory.cpp).
  std::vector<MemoryPart> memory_breakdown() const;

  // ---- Embedding API (docs/design.md, Embedding; world_embedding.cpp) -------------------------------
  // For programs that link dem::engine: build from a scene file, run with a callback at sync times,
  // read state, contact forces and wall loads, feed and discharge particles between sync intervals.
  // Every call below is made between sync intervals (never from inside the World's arena), and
  // none changes results' independence of the thread count.

  /// Builds a world from a scene file through the scene loader (scene_loader.h): its model,
  /// materials, contacts, walls, particles, integrator and [run] threads. `overrides` are applied
  /// as the CLI's --set ("integrator.dt=1e-4"). When `scene` is given it receives the loaded scene
  /// (its [run] and [output] settings are the caller's to use). Throws InputError (file, line, field)
  /// for a bad scene and std::invalid_argument as the constructor does.
  static std::unique_ptr<World> load(const std::string& scene_path, const std::vector<std::string>& overrides = {},
                                     Scene* scene = nullptr);

  /// Called at each sync time reached by run_until; return false to stop the run there. It may
  /// read the world and add or remove particles (it runs on the caller's thread, outside the arena).
  using SyncCallback = std::function<bool(World&)>;
  /// Advances one sync interval at a time until the first sync time at or after t [s], calling
  /// on_sync after every interval (not before the first). Stops early when on_sync returns false
  /// (the status is then ok and time() < t may hold) or when an interval returns non_finite (on_sync
  /// is not called for that interval).
  StepStatus run_until(Real t, const SyncCallback& on_sync);

  /// Particles now in the world.
  std::size_t particle_count() const { return state_.size(); }
  /// Storage slot of a particle in state(), or nothing for an id never given or removed.
  std::optional<ParticleIndex> index_of(ParticleId id) const;
  /// State of a live particle by its stable id; throw std::out_of_range for an id never given or removed.
  const Vec3& position(ParticleId id) const;          ///< [m]
  const Vec3& velocity(ParticleId id) const;          ///< [m/s]
  const Vec3& angular_velocity(ParticleId id) const;  ///< [rad/s]

  /// The live particles in id order as configs that rebuild them: id, position, velocity, angular
  /// velocity, radius, material, and the mass or the density each was given (its material's density
  /// when it was given neither), so a World made from them has the same ids, masses, inertias and
  /// radii bit for bit (what a settled file holds, engine/particle_csv.h).
  std::vector<ParticleConfig> particles() const;
  /// Every pair and wall contact of the last force evaluation: pairs in key order (ascending id
  /// pairs), then wall contacts in key order (ascending particle id, wall, feature). For each wall w,
  /// the sum of -force over its contacts is wall_loads()[w].force (Newton's third law).
  std::vector<ContactForce> contact_forces() const;
  /// Index of the wall with this name (WallConfig::name), or nothing.
  std::optional<std::size_t> find_wall(const std::string& name) const;

  /// True when a sphere of `radius` [m] at `position` [m] would touch no particle and no wall
  /// (a feed can test a spot before add_particle). 2D worlds use the position's x and y.
  bool is_free(const Vec3& position, Real radius) const;
  /// Adds a particle at the current sync time and returns its new id (ids are never reused).
  /// The particle must be in free space (is_free): throws std::invalid_argument when it overlaps a
  /// particle or a wall, names an unknown material, has a radius that is not > 0 and finite or a
  /// non-finite state.
  /// Contacts of the others keep their history; candidate pairs are rebuilt. Under step doubling
  /// it starts at the level particles start at (0, clamped to the levels). Energy books: its kinetic,
  /// rotational and potential energy join the balance's reference, as if present from the start.
  ParticleId add_particle(const ParticleConfig& particle);
  /// Removes a particle at the current sync time; false (and nothing changes) for an id never given
  /// or already removed. Its contacts end; every other contact keeps its history, the others'
  /// forces are re-summed without it, and candidate pairs are rebuilt. Energy books: what its
  /// contacts dissipated stays dissipated; its potential energy leaves the balance's reference;
  /// its kinetic and rotational energy and the elastic energy of its contacts' springs are booked
  /// as removed_energy(), which energy_balance() counts as energy carried out (so its error stays ~0).
  bool remove_particle(ParticleId id);
  /// Energy carried out by removed particles since the start [J] (see remove_particle).
  Real removed_energy() const { return removed_energy_; }
  /// Sets a live particle's velocity at the current sync time, as an impulse would: its position,
  /// spin, contacts and forces stay as they are; false (and nothing changes) for an id never given or
  /// removed, or a non-finite velocity. In 2D the z component must be 0. The kinetic energy it adds
  /// (or takes) is booked as given_energy(), which energy_balance() counts as energy put in.
  bool set_velocity(ParticleId id, const Vec3& velocity);
  /// Kinetic energy given to particles by set_velocity since the start [J] (negative: taken).
  Real given_energy() const { return given_energy_; }

 private:
  void add_particles();
  void evaluate_forces(Real h, bool force_rebuild);
  void evaluate_neighbour_forces(Real h, bool force_rebuild);
  /// Wall contacts anew from the current state (history by key), the ended ones booked; the wall
  /// lists, when rebuilt, reach `list_margin` [m] beyond each particle.
  void update_walls(Real list_margin);
  /// Makes pairs_ current from the persistent list when the last evaluation left it behind
  /// (thread-safe: const readers of one World may call it concurrently).
  void sync_pair_contacts() const;
  /// The deepest pair or wall contact of the current state (step_watch.h).
  Culprit deepest_contact_now() const;
  /// After pairs_ was changed directly (a checkpoint, a particle added or removed): the persistent
  /// list is made anew from it at the next evaluation.
  void pair_contacts_changed() { neighbours_stale_ = persistent_pairs_; }
  DashpotVelocity dashpot_velocity() const {
    return {config_.integrator.predicted_dashpot, gravity_, config_.model.dimension};
  }
  void rebuild_candidates();
  /// Re-sorts the particles in memory by spatial bins (fixed-step Verlet, at a candidate rebuild);
  /// the contact lists follow.
  void sort_particles();
  /// Puts the slots back in id order (a start under a control that needs it).
  void restore_id_order();
  /// Permutes the particles to `order` (State::permute), the compact contact lists with them.
  void permute_particles(const std::vector<std::uint32_t>& order);
  void step_exact(Real h);
  /// Takes a read and checked checkpoint's particles, contacts, books and neighbour lists
  /// (checkpoint.cpp); the clock, counters and levels are the caller's.
  void take_checkpoint(CheckpointContents& contents);
  /// The level every particle starts at: 0, within the doubling control's levels.
  int initial_level() const;
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
  /// Books the deepest contact now and, when given, the next step's longest travel (velocity Verlet
  /// at a fixed step measures it in its closing kick).
  void watch_step(const Culprit* travel);

  WorldConfig config_;
  int threads_ = 1;
  std::unique_ptr<TaskArena> arena_;
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
  WallLists wall_lists_;         // when use_wall_lists_
  bool use_wall_lists_ = false;  // config and any filtered wall (Walls::filtered)

  // Pair contacts. A fixed-step Verlet run keeps them in neighbours_ (one slot per candidate pair, the
  // history in it) and makes the compact pairs_ only when something reads it; the other runs use
  // pairs_ alone.
  mutable PairContacts pairs_;
  mutable bool pairs_stale_ = false;   // neighbours_ is newer than pairs_
  bool persistent_pairs_ = false;      // fixed control, velocity Verlet
  bool adaptive_skin_ = false;         // persistent_pairs_ and no skin in the scene
  // A chosen skin lasts the fastest particle about this many steps (evaluate_neighbour_forces).
  static constexpr Real skin_steps = 10;
  mutable std::mutex pairs_mutex_;     // sync_pair_contacts: const readers may call it concurrently
  bool neighbours_stale_ = true;       // pairs_ is newer than neighbours_
  NeighbourContacts neighbours_;
  mutable std::vector<std::uint32_t> compact_scratch_;
  WallContacts wall_contacts_;
  ContactAdjacency adjacency_;
  ContactWorkspace workspace_;
  RunCounters counters_;
  Real ended_dissipation_ = 0;  // dissipated by contacts that have ended [J]
  Real candidate_skin_ = 0;     // skin of the current candidate list [m] (the exact stepper widens it)
  std::int64_t sorted_at_ = -1;  // the sync interval of the last sort_particles; -1: none yet
  ExactWorkspace exact_work_;
  Real wall_work_ = 0;          // work of the walls on the particles [J]
  bool walls_move_ = false;     // any wall with prescribed velocity
  Energies start_energies_;     // at construction, for the energy balance
  Real exact_dissipated_ = 0;   // energy the exact stepper's contacts dissipated [J]
  std::unique_ptr<CollisionSpectra> spectra_;  // when booking contact events
  ContactEvents ended_events_;                 // scratch: the neighbour lists' ended contacts, booked at once
  std::unique_ptr<DoublingWork> doubling_;  // step doubling's islands and scratch
  // Embedding (world_embedding.cpp).
  void refresh_after_population_change();
  Real removed_energy_ = 0;     // kinetic, rotational and spring energy of removed particles [J]
  Real given_energy_ = 0;       // kinetic energy set_velocity added [J]
  Culprit deepest_seen_;        // step_watch.h
  Culprit travel_seen_;
};

}  // namespace dem

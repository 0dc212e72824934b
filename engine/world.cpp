#include "engine/world.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "engine/checkpoint.h"
#include "engine/doubling_work.h"
#include "engine/exact_stepper.h"
#include "engine/integrators.h"
#include "engine/parallel.h"
#include "engine/spatial_order.h"

namespace dem {
namespace {

RollingKind rolling_kind(const MaterialTable& m, RollingMode mode) {
  if (!m.any_rolling()) return RollingKind::none;
  return mode == RollingMode::seed ? RollingKind::seed : RollingKind::standard;
}

}  // namespace

World::World(const WorldConfig& config)
    : config_(config),
      materials_(config.materials, config.contacts, config.model.separation),
      walls_(config.walls, materials_),
      scheduler_(config.integrator) {
  if (config_.model.dimension != 2 && config_.model.dimension != 3)
    throw std::invalid_argument("model.dimension must be 2 or 3");
  // Embedding programs bypass the scene loader's checks: the ones a run cannot survive are here too.
  if (!(config_.integrator.dt > 0) || !std::isfinite(config_.integrator.dt))
    throw std::invalid_argument("integrator.dt must be a finite time step > 0 [s]");
  for (const ContactConfig& c : config_.contacts)
    if (!(c.normal_stiffness > 0) || c.tangential_stiffness == 0)
      throw std::invalid_argument("contact stiffnesses must be > 0 [N/m]");
  for (const ParticleConfig& p : config_.particles)
    if (!(p.radius > 0) || !std::isfinite(p.radius) || !p.position.allFinite() || !p.velocity.allFinite() ||
        !p.angular_velocity.allFinite())
      throw std::invalid_argument("every particle needs a finite radius > 0 and finite position and velocities");
  threads_ = config_.threads > 0 ? config_.threads : TaskArena::default_concurrency();
  arena_ = std::make_unique<TaskArena>(threads_);
  gravity_ = config_.model.gravity;
  kernels_ = select_force_kernels(config_.model.separation, materials_.any_friction(),
                                  rolling_kind(materials_, config_.model.rolling_mode));
  exact_work_.rolling = rolling_kind(materials_, config_.model.rolling_mode);
  add_particles();
  if (config_.broadphase.skin >= 0) {
    skin_ = config_.broadphase.skin;
  } else if (state_.size() > 0) {
    Real r_min = state_.radius[0];
    for (Real r : state_.radius) r_min = std::min(r_min, r);
    skin_ = 0.1 * r_min;
  }
  candidate_skin_ = skin_;
  persistent_pairs_ = config_.integrator.control == Control::fixed && config_.integrator.method == Method::verlet;
  // A scene that leaves the skin to us gets one that fits its speeds (evaluate_neighbour_forces),
  // from the default up to the smallest radius.
  adaptive_skin_ = persistent_pairs_ && config_.broadphase.skin < 0;
  for (std::size_t w = 0; w < walls_.count(); ++w)
    use_wall_lists_ = use_wall_lists_ || (config_.broadphase.wall_lists && walls_.filtered(w));
  // The exact stepper keeps no per-contact books: spectra need velocity Verlet (either control).
  const bool book_spectra = config_.collision_spectra && config_.integrator.method == Method::verlet;
  pairs_.parts = {materials_.any_friction(), materials_.any_rolling(), book_spectra};
  neighbours_stale_ = persistent_pairs_;
  arena_->execute([&] { evaluate_forces(0, true); });
  // Energy already in the springs at the start was not dissipated: count it as work done on them.
  PairContacts& pairs = persistent_pairs_ ? neighbours_.list : pairs_;
  pairs.work = pairs.elastic;
  wall_contacts_.work = wall_contacts_.elastic;
  for (EnergyBooks& b : pairs.books) b.normal_work = b.normal_elastic;
  for (ContactHistory& h : wall_contacts_.history) h.normal_work = h.normal_elastic;
  if (book_spectra) {
    spectra_ = std::make_unique<CollisionSpectra>(config_.spectra_size_classes);
    for (std::size_t p = 0; p < state_.size(); ++p) spectra_->classify(state_.id[p], state_.radius[p]);
  }
  for (const WallConfig& w : config_.walls)
    walls_move_ = walls_move_ || w.velocity.norm() > 0 || w.angular_velocity.norm() > 0;
  start_energies_ = energies();
  if (config_.integrator.control == Control::doubling) init_doubling();
}

World::~World() = default;

void World::add_particles() {
  const bool disc = config_.model.dimension == 2;
  const Real kappa = inertia_factor(config_.model.dimension);
  state_.reserve(state_.size() + config_.particles.size());
  for (std::size_t i = 0; i < config_.particles.size(); ++i) {
    ParticleConfig& p = config_.particles[i];
    const int mat = materials_.find(p.material);
    if (mat < 0) throw std::invalid_argument("particle names an unknown material '" + p.material + "'");
    const Real mass = particle_mass(p, materials_.density(static_cast<std::uint16_t>(mat)), config_.model.dimension,
                                    config_.model.thickness);
    const Real inv_mass = std::isinf(mass) ? 0 : 1 / mass;
    const Real inv_inertia = inv_mass / (kappa * p.radius * p.radius);
    Vec3 x = p.position, v = p.velocity, w = p.angular_velocity;
    if (disc) {
      x.z() = 0;
      v.z() = 0;
      w.x() = w.y() = 0;
    }
    if (p.id && *p.id < state_.next_id())
      throw std::invalid_argument("particle " + std::to_string(i) + " has id " + std::to_string(*p.id) +
                                  ", not above the ids before it: particles are added in id order, so given ids must "
                                  "increase along config.particles");
    const ParticleIndex slot = state_.add(p.id.value_or(state_.next_id()), x, v, w, p.radius, inv_mass, inv_inertia,
                                          static_cast<std::uint16_t>(mat));
    p.id = state_.id[slot];  // so particles() finds each particle's config by its id
  }
}

void World::evaluate_forces(Real h, bool force_rebuild) {
  if (persistent_pairs_) return evaluate_neighbour_forces(h, force_rebuild);
  const std::size_t n = state_.size();
  if (force_rebuild || skin_tracker_.needs_rebuild(state_.position, candidate_skin_)) rebuild_candidates();
  // Contacts that end are booked while the old list is still whole (it is updated in place).
  const EndedPairsHook book_ended = [&](const PairContacts& before, const std::vector<std::uint64_t>& after_key) {
    spectra_->record_ended(before, after_key);
  };
  ended_dissipation_ += update_pair_contacts(state_, candidates_, materials_, pairs_, workspace_, spectra_ ? book_ended : EndedPairsHook{});
  build_pair_adjacency(n, pairs_, adjacency_);
  update_walls(skin_);
  const DashpotVelocity dashpot = dashpot_velocity();
  kernels_.pair_forces(state_, materials_, pairs_, h, dashpot);
  kernels_.wall_forces(state_, materials_, walls_, wall_contacts_, workspace_.wall_touch, h, dashpot);
  gather_forces(state_, pairs_, wall_contacts_, adjacency_, kernels_.uses_rotation, config_.model.dimension);
}

void World::evaluate_neighbour_forces(Real h, bool force_rebuild) {
  const bool rebuild = force_rebuild || skin_tracker_.needs_rebuild(state_.position, candidate_skin_);
  if (rebuild && adaptive_skin_) {
    // Wide enough that the fastest particle, at its present speed, needs skin_steps steps to use half
    // of it: rebuilds every few steps (a mill's charge at a skin of a tenth of a radius) cost more
    // than the extra candidate pairs a wider skin tests. At most the smallest radius (ten default
    // skins; skin_ follows particles added later). Chosen from the state alone, so a resumed run
    // chooses as the straight one did.
    const Real reach = max_free_displacement(state_, gravity_, scheduler_.sync_interval());
    candidate_skin_ = std::clamp(2 * skin_steps * reach, skin_, 10 * skin_);
  }
  const int sort_interval = config_.broadphase.sort_interval;
  // Candidates and the skin check's reference positions are per slot: a sort comes just before a rebuild.
  if (rebuild && sort_interval > 0 && (sorted_at_ < 0 || clock_.interval - sorted_at_ >= sort_interval))
    sort_particles();
  if (rebuild) rebuild_candidates();
  if (rebuild || neighbours_stale_) {
    sync_pair_contacts();
    if (pairs_.row_start.size() != state_.size() + 1) pairs_.index_rows(state_.size());
    rebuild_neighbours(state_, candidates_, pairs_, neighbours_);
    neighbours_stale_ = false;
  }
  // pairs_ keeps the list the rebuild read until the next sync: finish_ended_contacts books the
  // contacts the rebuild left behind from it.
  pairs_stale_ = true;
  const DashpotVelocity dashpot = dashpot_velocity();
  kernels_.neighbour_forces(state_, materials_, neighbours_, h, dashpot);
  ended_dissipation_ += finish_ended_contacts(state_, neighbours_, pairs_, spectra_ ? &ended_events_ : nullptr);
  if (spectra_ && !ended_events_.events().empty()) {
    spectra_->record(ended_events_);
    ended_events_.clear();
  }
  update_walls(candidate_skin_);  // the lists take the skin chosen from the speeds, where it is
  kernels_.wall_forces(state_, materials_, walls_, wall_contacts_, workspace_.wall_touch, h, dashpot);
  gather_neighbour_forces(state_, neighbours_, wall_contacts_, adjacency_.wall_start, kernels_.uses_rotation,
                          config_.model.dimension);
}

void World::update_walls(Real list_margin) {
  // The lists give the same contacts as testing every wall, so when they are rebuilt changes nothing.
  if (use_wall_lists_ && !wall_lists_.valid(state_, walls_)) wall_lists_.build(state_, walls_, list_margin);
  ended_dissipation_ += update_wall_contacts(state_, walls_, materials_, wall_contacts_, workspace_,
                                             adjacency_.wall_start, use_wall_lists_ ? &wall_lists_ : nullptr);
  if (spectra_) spectra_->record_ended(workspace_.walls, wall_contacts_);
}

void World::sync_pair_contacts() const {
  const std::lock_guard<std::mutex> lock(pairs_mutex_);
  if (!pairs_stale_) return;
  arena_->execute([&] { compact_touching(state_, neighbours_, pairs_, compact_scratch_); });
  pairs_stale_ = false;
}

World::Culprit World::deepest_contact_now() const {
  // The persistent list's per-row deepest contacts hold from its last evaluation on; after a change
  // it has not seen yet (a checkpoint, a particle added or removed) the compact list is current.
  if (persistent_pairs_ && !neighbours_stale_) return deepest_contact(state_, neighbours_, wall_contacts_);
  return deepest_contact(state_, pair_contacts(), wall_contacts_);
}

void World::sort_particles() {
  // Bins of the largest diameter, as the grid broadphase's cells: a particle's partners lie in its
  // own bin and the next ones, so a sweep through the bins keeps them near in memory.
  const Real r_max = state_.size() > 0 ? *std::max_element(state_.radius.begin(), state_.radius.end()) : 0;
  permute_particles(bin_order(state_.position, 2 * r_max));
  sorted_at_ = static_cast<std::int64_t>(clock_.interval);
}

void World::restore_id_order() {
  if (state_.slots_follow_ids()) return;
  std::vector<std::uint32_t> order(state_.size());
  std::uint32_t q = 0;
  for (ParticleIndex slot : state_.index_of_id)
    if (slot != removed_slot) order[q++] = slot;
  permute_particles(order);
}

void World::permute_particles(const std::vector<std::uint32_t>& order) {
  // The compact list is current from here on, and the persistent list, in the old slots, is stale.
  sync_pair_contacts();
  pair_contacts_changed();
  state_.permute(order);
  std::vector<std::uint32_t> new_of_old(order.size());
  for (std::size_t q = 0; q < order.size(); ++q) new_of_old[order[q]] = static_cast<std::uint32_t>(q);
  dem::permute_particles(pairs_, new_of_old, workspace_.pairs);
  dem::permute_particles(wall_contacts_, new_of_old, workspace_.walls);
  wall_lists_.clear();  // per slot: made anew at the next evaluation
}

void World::rebuild_candidates() {
  if (config_.broadphase.use_kd_tree)
    kd_tree_.find_pairs(state_.position, state_.radius, candidate_skin_, candidates_);
  else
    grid_.find_pairs(state_.position, state_.radius, candidate_skin_, candidates_);
  skin_tracker_.reset(state_.position);
  ++counters_.pair_rebuilds;
}

void World::step_exact(Real h) {
  // The candidates must hold every pair the step may include (gap within anticipation_factor times
  // the relative reach, at most 2 reach): they cover gaps up to skin - 2 * (moves since the build),
  // so rebuild, with a skin wide enough for a few such steps, before that could fall short.
  const Real reach = anticipation_factor * max_free_displacement(state_, gravity_, h);
  if (skin_tracker_.max_displacement(state_.position) + reach > 0.5 * candidate_skin_) {
    candidate_skin_ = std::max(skin_, 4 * reach);
    rebuild_candidates();
  }
  const ExactSettings settings{config_.model.separation, gravity_, config_.model.dimension};
  const std::uint64_t retries = exact_work_.retries, unresolved = exact_work_.unresolved;
  const Real wall_work = exact_work_.wall_work;
  exact_dissipated_ += exact_step(state_, walls_, materials_, candidates_, settings, time(), h, exact_work_);
  wall_work_ += exact_work_.wall_work - wall_work;  // exact, flow by flow
  counters_.unresolved_contacts += exact_work_.unresolved - unresolved;
  // A step redone because it missed a contact costs a full trial: count it (docs/design.md, Counters).
  const std::uint64_t redone = (exact_work_.retries - retries) * state_.size();
  counters_.particle_steps += redone;
  counters_.rejected_steps += redone;
  counters_.force_evaluations += redone + state_.size();
}

StepStatus World::advance_sync_interval() {
  if (config_.integrator.control == Control::doubling) return advance_doubling_interval();
  // Fixed control: one step of dt per sync interval, every particle at level 0. Velocity Verlet:
  // kick, drift, forces, kick. Exact: scheme (D) of exact pair flows (exact_stepper.h), then the
  // contact forces of the new state for outputs (springs, wall loads; h = 0 leaves histories alone).
  const Real h = scheduler_.sync_interval();
  const bool rotation = kernels_.uses_rotation;
  const int dim = config_.model.dimension;
  bool finite = true;
  std::optional<Culprit> travel;  // velocity Verlet's, from its closing kick
  arena_->execute([&] {
    if (config_.integrator.method == Method::exact) {
      step_exact(h);
      ++clock_.interval;
      walls_.set_time(time());
      evaluate_forces(0, false);  // for outputs: contact list, springs, wall loads
    } else {
      kick_drift(state_, 0.5 * h, h, gravity_, rotation, dim);
      ++clock_.interval;
      walls_.set_time(time());
      evaluate_forces(h, false);
      counters_.force_evaluations += state_.size();
      // The closing kick checks the state and measures the next step's travel in the same pass.
      const KickCheck check = kick_and_check(state_, 0.5 * h, h, gravity_, rotation, dim);
      finite = check.finite;
      travel = check.travel;
    }
    // Work of moving walls, with the forces at the end of the step (a rectangle rule: an audit, not
    // the physics).
    if (walls_move_ && config_.integrator.method == Method::verlet) wall_work_ += h * wall_power(walls_, wall_contacts_);
    if (!travel) finite = state_is_finite();
    watch_step(travel ? &*travel : nullptr);
  });
  const std::uint64_t n = state_.size();
  counters_.sync_intervals += 1;
  counters_.particle_steps += n;
  counters_.accepted_steps += n;
  counters_.level_histogram.resize(1);  // everyone at level 0
  counters_.level_histogram[0] += n;
  return finite ? StepStatus::ok : StepStatus::non_finite;
}

StepStatus World::run_until(Real t) {
  while (time() < t) {
    const StepStatus status = advance_sync_interval();
    if (status != StepStatus::ok) return status;
  }
  return StepStatus::ok;
}

bool World::state_is_finite() const {
  return !parallel_any(state_.size(), [&](std::size_t p) { return !particle_is_finite(state_, p); });
}

std::vector<WallLoad> World::wall_loads() const {
  std::vector<WallLoad> loads;
  accumulate_wall_loads(walls_, wall_contacts_, loads);
  return loads;
}

Energies World::energies() const {
  sync_pair_contacts();
  Energies e;
  const State& s = state_;
  arena_->execute([&] {
    e.kinetic = block_sum<Real>(s.size(), [&](std::size_t p) {
      return is_audited(s.inv_mass[p]) ? 0.5 * s.velocity[p].squaredNorm() / s.inv_mass[p] : 0.0;
    });
    if (kernels_.uses_rotation)
      e.rotational = block_sum<Real>(s.size(), [&](std::size_t p) {
        return is_audited(s.inv_mass[p]) ? 0.5 * s.angular_velocity[p].squaredNorm() / s.inv_inertia[p] : 0.0;
      });
    e.potential = block_sum<Real>(s.size(), [&](std::size_t p) {
      return is_audited(s.inv_mass[p]) ? -gravity_.dot(s.position[p]) / s.inv_mass[p] : 0.0;
    });
    if (config_.integrator.method == Method::exact) {
      // The contact lists are evaluated only for outputs (h = 0): their normal springs are the exact
      // state's, but the tangential and rolling springs live in the exact stepper's history. (A pair
      // list books its normal spring apart only with collision spectra: k delta^2 / 2 from its overlap,
      // nothing where a force_zero contact's force is clamped to zero.)
      const std::vector<ExactHistoryRecord>& history = exact_work_.history;
      const auto pair_spring = [&](std::size_t k) {
        if (pairs_.force[k].isZero(0)) return Real{0};
        const Real k_n = materials_.params(materials_.pair_class(s.material[pairs_.i[k]], s.material[pairs_.j[k]])).k_n;
        return 0.5 * k_n * pairs_.overlap[k] * pairs_.overlap[k];
      };
      e.elastic = block_sum<Real>(pairs_.size(), pair_spring) +
                  block_sum<Real>(wall_contacts_.size(),
                                  [&](std::size_t k) { return wall_contacts_.history[k].normal_elastic; }) +
                  block_sum<Real>(history.size(), [&](std::size_t k) { return history[k].elastic; });
    } else {
      e.elastic = block_sum<Real>(pairs_.size(), [&](std::size_t k) { return pairs_.elastic[k]; }) +
                  block_sum<Real>(wall_contacts_.size(), [&](std::size_t k) { return wall_contacts_.elastic[k]; });
    }
  });
  return e;
}

Vec3 World::linear_momentum() const {
  Vec3 total = Vec3::Zero();
  arena_->execute([&] {
    total = block_sum<Vec3>(
        state_.size(),
        [&](std::size_t p) -> Vec3 {
          return is_audited(state_.inv_mass[p]) ? Vec3(state_.velocity[p] / state_.inv_mass[p]) : Vec3(Vec3::Zero());
        },
        Vec3::Zero());
  });
  return total;
}

World::Culprit World::fastest_particle() const {
  Culprit c;
  // Culprit::worse: a NaN wins (it is the culprit), ties go to the smaller id, so the slots' order
  // does not matter.
  for (std::size_t p = 0; p < state_.size(); ++p)
    c = Culprit::worse(c, Culprit{state_.id[p], state_.id[p], state_.velocity[p].norm(), 0});
  return c;
}

World::Culprit World::deepest_overlap() const {
  Culprit c;
  arena_->execute([&] { c = deepest_contact_now(); });
  c.time = time();
  return c;
}

void World::watch_step(const Culprit* travel) {
  Culprit deepest = deepest_contact_now();
  // The exact stepper's flows also report the deepest overlap inside the step (a whole impact may
  // fit in one); under doubling the islands pass theirs on in finish_round.
  if (config_.integrator.method == Method::exact && config_.integrator.control == Control::fixed)
    deepest = Culprit::worse(deepest, exact_work_.deepest);
  deepest.time = time();
  deepest_seen_ = Culprit::worse(deepest_seen_, deepest);
  if (travel) {
    Culprit at = *travel;
    at.time = time();
    travel_seen_ = Culprit::worse(travel_seen_, at);
  }
}

EnergyBalance World::energy_balance() const {
  const Energies now = energies();
  const Energies& e0 = start_energies_;
  const Real dissipated = dissipated_energy();
  // removed_energy_ and given_energy_: carried out by particles an embedding program removed, and
  // put in by the velocities it set (world_embedding.cpp).
  const Real error = (now.total() - e0.total()) + dissipated - wall_work_ + removed_energy_ - given_energy_;
  // What could legitimately have become motion: the start's kinetic, rotational and elastic energy,
  // the potential energy released, the work of the walls; plus what was dissipated.
  const Real scale = e0.kinetic + e0.rotational + e0.elastic + std::abs(now.potential - e0.potential) +
                     std::abs(dissipated) + std::abs(wall_work_) + std::abs(removed_energy_) +
                     std::abs(given_energy_);
  // Round-off floor: the potential energy is measured from the origin, so its sums carry ~1e-16 of
  // its size whatever moves; a scene with nothing in play must not be flagged for that.
  const Real floor = 1e-12 * (std::abs(e0.potential) + std::abs(now.potential)) + 1e-300;
  return {error, scale + floor};
}

Real World::dissipated_energy() const {
  if (config_.integrator.method == Method::exact) return exact_dissipated_;
  sync_pair_contacts();
  Real live = 0;
  arena_->execute([&] {
    live = live_dissipation(pairs_.work, pairs_.elastic) + live_dissipation(wall_contacts_.work, wall_contacts_.elastic);
  });
  return ended_dissipation_ + live;
}

std::uint64_t World::state_hash() const { return dem::state_hash(state_, pair_contacts(), wall_contacts_, clock_); }

}  // namespace dem

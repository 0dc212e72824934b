// Step doubling in the World (docs/physics.md 6; docs/design.md, Time).
// A sync interval is cut into rounds, each as long as the longest step the candidate skin allows.
// One round:
//   islands: contacts plus anticipated pairs (gap < 2 x the relative reach over the round)
//   -> each island, in parallel, cut out and advanced from the round's start to its end by
//      step doubling at its own levels (island_stepper.h), written to `next`
//   -> check: two islands whose particles came closer than their gap at the start (each
//      particle's farthest excursion counted) may have touched: they are merged and redone
//      together from the start of the round; a particle that outran the skin redoes the round
//      with a wider skin
//   -> `next` becomes the state; the islands' contacts become the World's lists (method exact: the
//      islands' wall-contact histories become the World's exact history).
// So a contact never spans two islands at different levels: rather than booking its impulse late on
// the coarser side, the two sides are integrated together (momentum exact and accuracy kept;
// docs/design.md, Time). Islands are independent, so results do not depend on thread count.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "engine/doubling_work.h"
#include "engine/parallel.h"
#include "engine/particle_level_doubling.h"
#include "engine/world.h"

namespace dem {
namespace {

Vec3 acceleration(const State& s, std::size_t p, const Vec3& gravity) {
  return s.inv_mass[p] == 0 ? Vec3(Vec3::Zero()) : Vec3(s.inv_mass[p] * s.force[p] + gravity);
}

/// A particle alone in its island, touching nothing, with no wall within twice its reach over h:
/// free flight, for which both steppers are exact at any step, so the error control would only
/// promote it; it takes the whole round in one step.
bool flies_free(const State& s, std::size_t p, const Walls& walls, const std::vector<std::uint32_t>& wall_start,
                const Vec3& gravity, Real h) {
  if (wall_start[p + 1] != wall_start[p]) return false;
  const Vec3 a = s.inv_mass[p] == 0 ? Vec3(Vec3::Zero()) : gravity;
  for (std::size_t w = 0; w < walls.count(); ++w) {
    const Real closing = (s.velocity[p] - walls.velocity_at(w, s.position[p])).norm() * h + 0.5 * a.norm() * h * h;
    if (walls.touching_count(w, s.position[p], s.radius[p] + 2 * closing) > 0) return false;
  }
  return true;
}

/// Velocity Verlet with no contact force (exact under uniform gravity), from `from` into `to`.
void free_flight(const State& from, std::size_t p, const Vec3& gravity, int dimension, Real h, State& to) {
  Vec3 v = from.velocity[p];
  const Vec3 g = from.inv_mass[p] == 0 ? Vec3(Vec3::Zero()) : gravity;
  v += 0.5 * h * g;
  to.position[p] = from.position[p] + h * v;
  v += 0.5 * h * g;
  if (dimension == 2) v.z() = 0;
  to.velocity[p] = v;
  to.angular_velocity[p] = from.angular_velocity[p];
  to.force[p].setZero();
  to.torque[p].setZero();
}

}  // namespace

int World::initial_level() const {
  const IntegratorConfig& c = config_.integrator;
  return c.control == Control::doubling ? std::clamp(0, c.level_min, c.level_max) : 0;
}

void World::init_doubling() {
  const IntegratorConfig& c = config_.integrator;
  // Levels are stored per particle in 8 bits; the scene loader keeps them in [-100, 100] too.
  if (c.level_min > c.level_max || c.level_min < -100 || c.level_max > 100 || c.level_max - c.level_min > 40)
    throw std::invalid_argument("integrator levels must satisfy -100 <= level_min <= level_max <= 100 and "
                                "level_max - level_min <= 40");
  if (c.particle_levels && (c.method == Method::exact || c.predicted_dashpot))
    throw std::invalid_argument("integrator.particle_levels needs method verlet (the exact stepper keeps one level per "
                                "touching set) and does not combine with predicted_dashpot yet");
  IslandScratch exemplar;
  exemplar.walls = walls_;
  exemplar.exact.rolling = exact_work_.rolling;
  doubling_ = std::make_unique<DoublingWork>(exemplar);
  DoublingWork& d = *doubling_;
  d.physics = IslandPhysics{&materials_, kernels_, gravity_, config_.model.dimension, c.method,
                            config_.model.separation, walls_move_, dashpot_velocity(), spectra_ != nullptr,
                            use_wall_lists_ ? skin_ : 0};
  for (auto& level : state_.level) level = static_cast<std::int8_t>(initial_level());
  // A particle that touches something at the start begins at level_min: its contacts' tangential and
  // rolling springs start from zero there, a transient as short as the friction's ramp (mu N / (k_t v)
  // for a sliding one), which no anticipation bounds; the error control lengthens the step from there.
  const auto start_fine = [&](ParticleIndex p) { state_.level[p] = static_cast<std::int8_t>(c.level_min); };
  for (std::size_t k = 0; k < pairs_.size(); ++k) start_fine(pairs_.i[k]), start_fine(pairs_.j[k]);
  for (std::size_t k = 0; k < wall_contacts_.size(); ++k) start_fine(wall_contacts_.particle[k]);
  // Anticipation demotes an approaching particle down to a step of t_c / 8 for the stiffest contact
  // and the lightest pair (m* = m / 2), the most a contact may need to be resolved.
  Real k_max = 0, inv_mass_max = 0, r_max = 0;
  for (const ContactConfig& contact : config_.contacts) k_max = std::max(k_max, contact.normal_stiffness);
  for (std::size_t p = 0; p < state_.size(); ++p) {
    inv_mass_max = std::max(inv_mass_max, state_.inv_mass[p]);
    r_max = std::max(r_max, state_.radius[p]);
  }
  d.contact_level = c.level_max;
  if (k_max > 0 && inv_mass_max > 0)
    d.contact_level = contact_resolving_level(k_max, 2 * inv_mass_max, scheduler_.dt_base(), c.level_min, c.level_max);
  d.skin_cap = std::max(skin_, 2 * r_max);
  d.round_walls = walls_;
  d.next = state_;
  d.excursion.assign(state_.size(), 0);
}

StepStatus World::advance_doubling_interval() {
  const std::int64_t ticks = scheduler_.ticks_per_interval();
  bool finite = true;
  arena_->execute([&] {
    clock_.tick = 0;
    while (clock_.tick < ticks) {
      const int level = round_level(clock_.tick);
      run_round(clock_.tick, level);
      clock_.tick += ticks_of_level(level, scheduler_.level_min());
      // The World's contact lists are the islands' at the round's end (Verlet): watch them there.
      if (config_.integrator.method == Method::verlet) watch_step(nullptr);
    }
    clock_.tick = 0;
    ++clock_.interval;
    walls_.set_time(time());
    if (config_.integrator.method == Method::exact) {
      evaluate_forces(0, false);  // for outputs and islands
      watch_step(nullptr);
    }
    finite = state_is_finite();
  });
  counters_.sync_intervals += 1;
  return finite ? StepStatus::ok : StepStatus::non_finite;
}

int World::round_level(std::int64_t tick) {
  const int level_min = scheduler_.level_min();
  const std::int64_t ticks = scheduler_.ticks_per_interval();
  int level = scheduler_.level_max();
  level = aligned_level(level, level_min, tick, ticks);
  // How far any particle can go in a step of h: |v| h + |a| h^2 / 2, bounded from the largest
  // speed and acceleration (max is exact, so the bound is the same for any thread count).
  Real speed = 0, accel = 0;
  for (std::size_t p = 0; p < state_.size(); ++p) {
    if (state_.inv_mass[p] == 0) continue;
    speed = std::max(speed, state_.velocity[p].norm());
    accel = std::max(accel, acceleration(state_, p, gravity_).norm());
  }
  auto reach = [&](int l) {
    const Real h = scheduler_.step_of_level(l);
    return speed * h + 0.5 * accel * h * h;
  };
  // The skin caps the round: a round longer than the skin covers would need too many candidates. A
  // world of one particle has no candidate pairs, its walls are tested at every evaluation and its
  // overlaps watched at every accepted step, so only the sync interval bounds its rounds.
  if (state_.size() > 1)
    while (level > level_min && 8 * reach(level) > doubling_->skin_cap) --level;
  const Real moved = skin_tracker_.max_displacement(state_.position);
  if (!(moved + 2 * reach(level) <= 0.5 * candidate_skin_)) {
    candidate_skin_ = std::max(skin_, 8 * reach(level));
    rebuild_candidates();
  }
  return level;
}

void World::find_round_islands(Real h) {
  DoublingWork& d = *doubling_;
  const State& s = state_;
  // The exact stepper's lists are refreshed only at sync times: it links touching pairs by the gap below.
  const bool contacts_current = config_.integrator.method == Method::verlet;
  d.link_a.assign(contacts_current ? pairs_.i.begin() : pairs_.i.end(), pairs_.i.end());
  d.link_b.assign(contacts_current ? pairs_.j.begin() : pairs_.j.end(), pairs_.j.end());
  // Anticipated pairs: those that could close half their gap within the round.
  for (std::size_t a = 0; a < s.size(); ++a) {
    for (std::uint32_t k = candidates_.row_start[a]; k < candidates_.row_start[a + 1]; ++k) {
      const ParticleIndex b = candidates_.partner[k];
      if (s.inv_mass[a] == 0 && s.inv_mass[b] == 0) continue;
      const Real gap = (s.position[a] - s.position[b]).norm() - s.radius[a] - s.radius[b];
      const Real closing = (s.velocity[a] - s.velocity[b]).norm() * h +
                           0.5 * (acceleration(s, a, gravity_) - acceleration(s, b, gravity_)).norm() * h * h;
      if (gap < 2 * closing || gap <= 0) {
        d.link_a.push_back(static_cast<ParticleIndex>(a));
        d.link_b.push_back(b);
      }
    }
  }
  d.link_a.insert(d.link_a.end(), d.conflict_a.begin(), d.conflict_a.end());
  d.link_b.insert(d.link_b.end(), d.conflict_b.begin(), d.conflict_b.end());
  find_islands(s.size(), d.link_a, d.link_b, d.islands);
  d.local_index.resize(s.size());
  for (std::size_t k = 0; k < d.islands.count(); ++k)
    for (std::uint32_t q = d.islands.start[k]; q < d.islands.start[k + 1]; ++q)
      d.local_index[d.islands.member[q]] = q - d.islands.start[k];
}

namespace {

/// Appends the records of particle `id` from a list sorted by exact_history_key (they are adjacent).
void append_exact_history(const std::vector<ExactHistoryRecord>& from, ParticleId id,
                          std::vector<ExactHistoryRecord>& to) {
  const std::uint64_t first = std::uint64_t{id} << 32, last = first + (std::uint64_t{1} << 32);
  const auto by_key = [](const ExactHistoryRecord& r, std::uint64_t x) { return r.key < x; };
  const auto begin = std::lower_bound(from.begin(), from.end(), first, by_key);
  const auto end = std::lower_bound(begin, from.end(), last, by_key);
  to.insert(to.end(), begin, end);
}

/// Cuts island k out of the World's state, candidates and contact lists (Verlet: `with_contacts`), or
/// its members' exact wall-contact history (exact: `exact_history`, sorted by key).
void gather_island(const Islands& islands, const std::vector<std::uint32_t>& local, std::size_t k, const State& s,
                   const broadphase::CandidatePairs& candidates, const PairContacts& pairs,
                   const WallContacts& walls, const std::vector<std::uint32_t>& wall_start, bool with_contacts,
                   const std::vector<ExactHistoryRecord>* exact_history, IslandJob& job) {
  const ParticleIndex* member = islands.member.data() + islands.start[k];
  const std::size_t m = islands.start[k + 1] - islands.start[k];
  State& t = job.island.state;
  t.id.resize(m), t.position.resize(m), t.velocity.resize(m), t.angular_velocity.resize(m), t.force.resize(m);
  t.torque.resize(m), t.radius.resize(m), t.inv_mass.resize(m), t.inv_inertia.resize(m), t.material.resize(m);
  t.level.resize(m);
  t.index_of_id.clear();
  auto& cand = job.candidates;
  cand.row_start.assign(1, 0);
  cand.partner.clear();
  PairContacts& cp = job.island.pairs;
  WallContacts& cw = job.island.walls;
  std::size_t pair_count = 0, wall_count = 0;
  for (std::size_t q = 0; q < m && with_contacts; ++q) {
    pair_count += pairs.row_start[member[q] + 1] - pairs.row_start[member[q]];
    wall_count += wall_start[member[q] + 1] - wall_start[member[q]];
  }
  cp.parts = pairs.parts;
  cp.resize(pair_count);
  cp.row_start.assign(1, 0);
  cw.resize(wall_count);
  std::size_t pk = 0, wk = 0;
  for (std::size_t q = 0; q < m; ++q) {
    const ParticleIndex a = member[q];
    t.id[q] = s.id[a], t.position[q] = s.position[a], t.velocity[q] = s.velocity[a];
    t.angular_velocity[q] = s.angular_velocity[a], t.force[q] = s.force[a], t.torque[q] = s.torque[a];
    t.radius[q] = s.radius[a], t.inv_mass[q] = s.inv_mass[a], t.inv_inertia[q] = s.inv_inertia[a];
    t.material[q] = s.material[a], t.level[q] = s.level[a];
    for (std::uint32_t c = candidates.row_start[a]; c < candidates.row_start[a + 1]; ++c) {
      const ParticleIndex b = candidates.partner[c];
      if (islands.island_of[b] == k) cand.partner.push_back(local[b]);
    }
    cand.row_start.push_back(static_cast<std::uint32_t>(cand.partner.size()));
    if (!with_contacts) continue;
    for (std::uint32_t c = pairs.row_start[a]; c < pairs.row_start[a + 1]; ++c, ++pk) {
      copy_pair(pairs, c, cp, pk);
      cp.i[pk] = local[pairs.i[c]], cp.j[pk] = local[pairs.j[c]];
    }
    cp.row_start.push_back(static_cast<std::uint32_t>(pk));
    for (std::uint32_t c = wall_start[a]; c < wall_start[a + 1]; ++c, ++wk) {
      cw.key[wk] = walls.key[c], cw.particle[wk] = static_cast<ParticleIndex>(q), cw.wall[wk] = walls.wall[c];
      cw.feature[wk] = walls.feature[c], cw.history[wk] = walls.history[c];
      cw.overlap[wk] = walls.overlap[c], cw.work[wk] = walls.work[c], cw.elastic[wk] = walls.elastic[c];
      cw.point[wk] = walls.point[c], cw.force[wk] = walls.force[c], cw.torque[wk] = walls.torque[c];
      cw.rolling_torque[wk] = walls.rolling_torque[c];
    }
  }
  job.island.adjacency.wall_start.clear();
  job.island.ended_dissipation = job.island.exact_dissipated = job.island.wall_work = 0;
  job.island.events.clear();
  job.island.deepest = Worst{};
  job.island.unresolved = 0;
  std::vector<ExactHistoryRecord>& history = job.island.exact_history;
  history.clear();
  if (exact_history && !exact_history->empty()) {
    for (std::size_t q = 0; q < m; ++q) append_exact_history(*exact_history, t.id[q], history);
    // Members are in slot order; ids need not be.
    const auto by_key = [](const ExactHistoryRecord& x, const ExactHistoryRecord& y) { return x.key < y.key; };
    if (!std::is_sorted(history.begin(), history.end(), by_key)) std::sort(history.begin(), history.end(), by_key);
  }
}

}  // namespace

void World::run_islands(const std::vector<std::uint32_t>& which, std::int64_t tick, int level) {
  DoublingWork& d = *doubling_;
  const IntegratorConfig& c = config_.integrator;
  DoublingSettings settings;
  settings.level_min = scheduler_.level_min();
  settings.level_max = level;
  settings.dt_base = scheduler_.dt_base();
  settings.tolerance = c.tolerance;
  settings.safety = c.safety;
  settings.velocity_weight = c.velocity_weight;
  settings.dx_min = c.dx_min;
  settings.reference_time = c.error_per_unit_step ? scheduler_.sync_interval() : 0;
  settings.richardson = c.richardson;
  settings.contact_level = d.contact_level;
  const Real t0 = scheduler_.time(Clock{clock_.interval, 0});
  const std::int64_t end = tick + ticks_of_level(level, settings.level_min);
  const Real h = scheduler_.step_of_level(level);
  d.round_walls.set_time(t0 + static_cast<Real>(tick) * scheduler_.step_of_level(settings.level_min));
  const Real bulge = 0.125 * gravity_.norm() * h * h;  // farthest a parabola strays from its chord
  const bool per_particle = c.particle_levels && c.method == Method::verlet;
  // Particles in free flight take the round in one step; the other islands get a job.
  parallel_for(which.size(), [&](std::size_t w) {
    const std::uint32_t k = which[w];
    d.job_of[k] = needs_job;
    if (d.islands.start[k + 1] - d.islands.start[k] != 1) return;
    const ParticleIndex a = d.islands.member[d.islands.start[k]];
    if (!flies_free(state_, a, d.round_walls, adjacency_.wall_start, gravity_, h)) return;
    free_flight(state_, a, gravity_, config_.model.dimension, h, d.next);
    d.next.level[a] = static_cast<std::int8_t>(level);
    d.excursion[a] = (d.next.position[a] - state_.position[a]).norm() + bulge;
    d.job_of[k] = in_free_flight;
    DoublingCounters& counters = d.counters.local();
    counters.particle_steps += 1;
    counters.force_evaluations += 1;
    counters.accepted += 1;
    const std::size_t levels = level - settings.level_min + 1;
    if (counters.histogram.size() < levels) counters.histogram.resize(levels, 0);
    ++counters.histogram[level - settings.level_min];
  });
  std::vector<std::uint32_t> busy;
  for (std::uint32_t k : which)
    if (d.job_of[k] == needs_job) {
      d.job_of[k] = static_cast<std::int32_t>(d.job_count++);
      busy.push_back(k);
    }
  if (d.jobs.size() < d.job_count) d.jobs.resize(d.job_count);
  const auto run_island = [&](std::size_t w) {
    const std::uint32_t k = busy[w];
    IslandJob& job = d.jobs[d.job_of[k]];
    // The exact stepper finds its contacts from the positions; it keeps only its wall contacts'
    // tangential and rolling history, by particle id.
    gather_island(d.islands, d.local_index, k, state_, candidates_, pairs_, wall_contacts_, adjacency_.wall_start,
                  c.method == Method::verlet, c.method == Method::exact ? &exact_work_.history : nullptr, job);
    std::vector<int>& levels = job.levels;
    levels.assign(job.island.state.level.begin(), job.island.state.level.end());
    if (per_particle) {
      advance_island_per_particle(job.island, job.candidates, d.physics, settings, d.scratch.local(), t0,
                                  tick, end, levels, d.counters.local());
    } else {
      const int start_level = *std::min_element(levels.begin(), levels.end());
      levels.assign(levels.size(), advance_island(job.island, job.candidates, d.physics, settings,
                                                  d.scratch.local(), t0, tick, end, start_level, d.counters.local()));
    }
    // Scatter the particles; contacts stay in the job until the round is accepted.
    const ParticleIndex* member = d.islands.member.data() + d.islands.start[k];
    const State& t = job.island.state;
    for (std::size_t q = 0; q < t.size(); ++q) {
      const ParticleIndex a = member[q];
      d.next.position[a] = t.position[q], d.next.velocity[a] = t.velocity[q];
      d.next.angular_velocity[a] = t.angular_velocity[q];
      d.next.force[a] = t.force[q], d.next.torque[a] = t.torque[q];
      d.next.level[a] = static_cast<std::int8_t>(levels[q]);
      d.excursion[a] = job.island.excursion[q];
    }
  };
  // Each island runs isolated: a thread waiting in an island's own parallel loops takes no other
  // island's task, which would reuse this thread's scratch (its walls set to another time) meanwhile.
  parallel_for(busy.size(), [&](std::size_t w) { isolated([&] { run_island(w); }); }, 1);
}

bool World::find_conflicts() {
  // Two particles of different islands could have touched during the round only if their gap at
  // the start was within the sum of their excursions (a particle's path never leaves the ball of
  // its excursion about its start).
  DoublingWork& d = *doubling_;
  const State& s = state_;
  bool found = false;
  for (std::size_t a = 0; a < s.size(); ++a) {
    for (std::uint32_t k = candidates_.row_start[a]; k < candidates_.row_start[a + 1]; ++k) {
      const ParticleIndex b = candidates_.partner[k];
      if (d.islands.island_of[a] == d.islands.island_of[b]) continue;
      if (s.inv_mass[a] == 0 && s.inv_mass[b] == 0) continue;
      const Real gap = (s.position[a] - s.position[b]).norm() - s.radius[a] - s.radius[b];
      if (gap <= d.excursion[a] + d.excursion[b]) {
        d.conflict_a.push_back(static_cast<ParticleIndex>(a));
        d.conflict_b.push_back(b);
        found = true;
      }
    }
  }
  return found;
}

void World::run_round(std::int64_t tick, int level) {
  DoublingWork& d = *doubling_;
  const Real h = scheduler_.step_of_level(level);
  d.conflict_a.clear();
  d.conflict_b.clear();
  find_round_islands(h);
  std::vector<std::uint32_t> which(d.islands.count());
  for (std::size_t k = 0; k < which.size(); ++k) which[k] = static_cast<std::uint32_t>(k);
  d.job_of.assign(d.islands.count(), needs_job);
  d.job_count = 0;
  for (;;) {
    run_islands(which, tick, level);
    // A particle beyond half the skin from where the candidates were built may have met a pair
    // the list does not hold: widen the skin and redo the whole round.
    const auto reference = skin_tracker_.reference();
    const bool outran = parallel_any(state_.size(), [&](std::size_t p) {
      return !((state_.position[p] - reference[p]).norm() + d.excursion[p] <= 0.5 * candidate_skin_);
    });
    if (outran) {
      ++counters_.round_redos;
      candidate_skin_ *= 2;
      rebuild_candidates();
      d.conflict_a.clear();
      d.conflict_b.clear();
    } else if (find_conflicts()) {
      ++counters_.round_redos;
    } else {
      break;
    }
    // Redo the islands that changed; the others keep their result.
    const Islands before = d.islands;
    const std::vector<std::int32_t> job_before = d.job_of;
    find_round_islands(h);
    d.job_of.assign(d.islands.count(), needs_job);
    which.clear();
    for (std::uint32_t k = 0; k < d.islands.count(); ++k) {
      const ParticleIndex first = d.islands.member[d.islands.start[k]];
      const std::uint32_t old = before.island_of[first];
      const bool same = !outran && before.start[old + 1] - before.start[old] == d.islands.start[k + 1] - d.islands.start[k];
      if (same) d.job_of[k] = job_before[old];
      else which.push_back(k);
    }
  }
  finish_round();
}

void World::finish_round() {
  DoublingWork& d = *doubling_;
  const std::size_t n = state_.size();
  const std::size_t islands = d.islands.count();
  // Energy books of the islands, summed in island order.
  for (std::size_t k = 0; k < islands; ++k) {
    if (d.job_of[k] < 0) continue;  // free flight
    const IslandJob& job = d.jobs[d.job_of[k]];
    ended_dissipation_ += job.island.ended_dissipation;
    if (spectra_) spectra_->record(job.island.events);
    exact_dissipated_ += job.island.exact_dissipated;
    deepest_seen_ = Culprit::worse(deepest_seen_, job.island.deepest);  // stamped with its step's end
    wall_work_ += job.island.wall_work;
    counters_.unresolved_contacts += job.island.unresolved;
  }
  std::swap(state_.position, d.next.position);
  std::swap(state_.velocity, d.next.velocity);
  std::swap(state_.angular_velocity, d.next.angular_velocity);
  std::swap(state_.force, d.next.force);
  std::swap(state_.torque, d.next.torque);
  std::swap(state_.level, d.next.level);
  // Counters: integer sums, the same in any order.
  d.counters.for_each([&](DoublingCounters& local) {
    counters_.accepted_steps += local.accepted;
    counters_.rejected_steps += local.rejected;
    counters_.forced_steps += local.forced;
    counters_.particle_steps += local.particle_steps;
    counters_.force_evaluations += local.force_evaluations;
    counters_.richardson_steps += local.richardson;
    counters_.member_retries += local.member_retries;
    auto& histogram = counters_.level_histogram;
    if (histogram.size() < local.histogram.size()) histogram.resize(local.histogram.size(), 0);
    for (std::size_t k = 0; k < local.histogram.size(); ++k) histogram[k] += local.histogram[k];
    local = DoublingCounters{};
  });
  if (config_.integrator.method == Method::exact) {
    // Contacts are found again from positions; the wall-contact histories of the accepted trials
    // become the World's, in key order. A particle in free flight touches no wall: it has none.
    std::vector<ExactHistoryRecord>& history = exact_work_.history;
    history.clear();
    for (std::size_t k = 0; k < islands; ++k)
      if (d.job_of[k] >= 0) {
        const std::vector<ExactHistoryRecord>& own = d.jobs[d.job_of[k]].island.exact_history;
        history.insert(history.end(), own.begin(), own.end());
      }
    std::sort(history.begin(), history.end(),
              [](const ExactHistoryRecord& x, const ExactHistoryRecord& y) { return x.key < y.key; });
    return;
  }
  // The islands' contact lists become the World's, in the World's order: by row (smaller slot),
  // then key for pairs; by particle, then key for walls.
  std::vector<std::uint32_t>& pair_count = workspace_.count;
  pair_count.assign(n, 0);
  std::vector<std::uint32_t> wall_count(n, 0);
  parallel_for(
      islands,
      [&](std::size_t k) {
        if (d.job_of[k] < 0) return;  // free flight: no contacts
        const IslandState& is = d.jobs[d.job_of[k]].island;
        const ParticleIndex* member = d.islands.member.data() + d.islands.start[k];
        for (std::size_t q = 0; q < is.state.size(); ++q) {
          pair_count[member[q]] = is.pairs.row_start[q + 1] - is.pairs.row_start[q];
          wall_count[member[q]] = is.adjacency.wall_start[q + 1] - is.adjacency.wall_start[q];
        }
      },
      1);
  PairContacts& fresh = workspace_.pairs;
  WallContacts& fresh_walls = workspace_.walls;
  fresh.parts = pairs_.parts;
  exclusive_scan(pair_count, fresh.row_start);
  exclusive_scan(wall_count, adjacency_.wall_start);
  fresh.resize(fresh.row_start[n]);
  fresh_walls.resize(adjacency_.wall_start[n]);
  parallel_for(
      islands,
      [&](std::size_t k) {
        if (d.job_of[k] < 0) return;
        const IslandState& is = d.jobs[d.job_of[k]].island;
        const ParticleIndex* member = d.islands.member.data() + d.islands.start[k];
        const PairContacts& cp = is.pairs;
        const WallContacts& cw = is.walls;
        for (std::size_t q = 0; q < is.state.size(); ++q) {
          std::uint32_t slot = fresh.row_start[member[q]];
          for (std::uint32_t c = cp.row_start[q]; c < cp.row_start[q + 1]; ++c, ++slot) {
            copy_pair(cp, c, fresh, slot);
            fresh.i[slot] = member[cp.i[c]], fresh.j[slot] = member[cp.j[c]];
          }
          slot = adjacency_.wall_start[member[q]];
          for (std::uint32_t c = is.adjacency.wall_start[q]; c < is.adjacency.wall_start[q + 1]; ++c, ++slot) {
            copy_wall(cw, c, fresh_walls, slot);
            fresh_walls.particle[slot] = member[q];
          }
        }
      },
      1);
  std::swap(pairs_, fresh);
  std::swap(wall_contacts_, fresh_walls);
  build_pair_adjacency(n, pairs_, adjacency_);
}

}  // namespace dem

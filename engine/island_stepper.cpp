#include "engine/island_stepper.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "engine/integrators.h"
#include "engine/scheduler.h"
#include "engine/step_control.h"
#include "engine/step_watch.h"

namespace dem {
namespace {

/// Merges an overlap seen at `time` [s] into s.deepest (the first of equals, NaN first).
void merge_deepest(IslandState& s, Worst at, Real time) {
  at.time = time;
  s.deepest = Worst::worse(s.deepest, at);
}

/// Contacts from the current positions and their forces; h is the step the springs advance by.
void evaluate_forces(IslandState& s, const broadphase::CandidatePairs& candidates, const IslandPhysics& physics,
                     IslandScratch& scratch, Real h) {
  State& st = s.state;
  // Contacts that end are logged while the old list is still whole (as World::evaluate_forces books them).
  EndedPairsHook log_ended;
  if (physics.book_events)
    log_ended = [&s](const PairContacts& before, const std::vector<std::uint64_t>& after_key) {
      s.events.record_ended(before, after_key);
    };
  s.ended_dissipation += update_pair_contacts(st, candidates, *physics.materials, s.pairs, scratch.contacts, log_ended);
  build_pair_adjacency(st.size(), s.pairs, s.adjacency);
  s.ended_dissipation +=
      update_wall_contacts(st, scratch.walls, *physics.materials, s.walls, scratch.contacts, s.adjacency.wall_start);
  if (physics.book_events) s.events.record_ended(scratch.contacts.walls, s.walls);
  physics.kernels.pair_forces(st, *physics.materials, s.pairs, h, physics.dashpot);
  physics.kernels.wall_forces(st, *physics.materials, scratch.walls, s.walls, scratch.contacts.wall_touch, h,
                              physics.dashpot);
  gather_forces(st, s.pairs, s.walls, s.adjacency, physics.kernels.uses_rotation, physics.dimension);
}

/// One step of h from time t with the run's method; returns the particle-steps a redo cost.
std::uint64_t step(IslandState& s, const broadphase::CandidatePairs& candidates, const IslandPhysics& physics,
                   IslandScratch& scratch, Real t, Real h) {
  State& st = s.state;
  if (physics.method == Method::exact) {
    const ExactSettings settings{physics.separation, physics.gravity, physics.dimension};
    const std::uint64_t retries = scratch.exact.retries, unresolved = scratch.exact.unresolved;
    const Real wall_work = scratch.exact.wall_work;
    // The trial's own wall-contact history stands in for the workspace's while it steps.
    std::swap(scratch.exact.history, s.exact_history);
    s.exact_dissipated += exact_step(st, scratch.walls, *physics.materials, candidates, settings, t, h, scratch.exact);
    merge_deepest(s, scratch.exact.deepest, t + h);
    std::swap(scratch.exact.history, s.exact_history);
    s.wall_work += scratch.exact.wall_work - wall_work;
    s.unresolved += scratch.exact.unresolved - unresolved;
    return (scratch.exact.retries - retries) * st.size();
  }
  const bool rotation = physics.kernels.uses_rotation;
  kick(st, 0.5 * h, physics.gravity, rotation, physics.dimension);
  drift(st, h);
  scratch.walls.set_time(t + h);
  evaluate_forces(s, candidates, physics, scratch, h);
  kick(st, 0.5 * h, physics.gravity, rotation, physics.dimension);
  // Work of moving walls, with the forces at the end of the step (a rectangle rule: an audit only).
  if (physics.walls_move) s.wall_work += h * wall_power(scratch.walls, s.walls);
  return 0;
}

/// Widens each member's excursion to its current distance from the start of the round; `bulge`
/// bounds how far a path strays from the chord between step ends (0 for Verlet's straight drift).
void track_excursion(IslandState& s, const std::vector<Vec3>& origin, Real bulge) {
  for (std::size_t q = 0; q < s.state.size(); ++q)
    s.excursion[q] = std::max(s.excursion[q], (s.state.position[q] - origin[q]).norm() + bulge);
}

/// T of the error norm (step_control.h) for a step of h.
Real reference_time(const DoublingSettings& settings, Real h) {
  return settings.reference_time > 0 ? settings.reference_time : h;
}

/// Largest error of seed formula (3) over the island's movable members; NaN if any is NaN.
Real island_error(const IslandState& start, const IslandState& full, const IslandState& half, Real h,
                  const DoublingSettings& settings) {
  Real worst = 0;
  const State& a = full.state;
  const State& b = half.state;
  for (std::size_t q = 0; q < a.size(); ++q) {
    if (a.inv_mass[q] == 0) continue;
    const TrialState one{a.position[q], a.velocity[q], a.angular_velocity[q]};
    const TrialState two{b.position[q], b.velocity[q], b.angular_velocity[q]};
    const Real e = step_error(one, two, b.position[q] - start.state.position[q], h, reference_time(settings, h),
                              a.radius[q], settings.velocity_weight, settings.dx_min);
    if (!(e <= worst)) worst = e;  // NaN wins, so a broken trial is rejected
  }
  return worst;
}

/// Error bound for a step in which a contact began, ended or changed mode: both trials place the
/// event at the end of a (half) step, so their difference can miss it entirely, while its time is
/// only known to within h/2. The acceleration jumps by about |a_end - a_start|; a late switch by
/// h/2 errs by that times h/2 in velocity and h^2/8 in position. Same norm as seed formula (3).
Real event_error(const IslandState& start, const IslandState& end, Real h, const DoublingSettings& settings) {
  Real worst = 0;
  const State& a = start.state;
  const State& b = end.state;
  const Real weight = settings.velocity_weight * reference_time(settings, h);
  for (std::size_t q = 0; q < a.size(); ++q) {
    if (a.inv_mass[q] == 0) continue;
    const Real jump = a.inv_mass[q] * (b.force[q] - a.force[q]).norm();
    const Real spin_jump = a.inv_inertia[q] * (b.torque[q] - a.torque[q]).norm();
    const Real numerator = jump * h * h / 8 + weight * (jump + a.radius[q] * spin_jump) * h / 2;
    const Real e = numerator / ((b.position[q] - a.position[q]).norm() +
                                settings.dx_min * a.radius[q] * h / reference_time(settings, h));
    if (!(e <= worst)) worst = e;
  }
  return worst;
}

/// The same contacts in the same modes at the start and at the end of both trials: no event
/// (onset, release, mode change) happened, so the Richardson value is sound (docs/physics.md 6.7).
bool same_contacts(const IslandState& start, const IslandState& full, const IslandState& half) {
  if (start.pairs.key != half.pairs.key || full.pairs.key != half.pairs.key) return false;
  if (start.walls.key != half.walls.key || full.walls.key != half.walls.key) return false;
  for (std::size_t k = 0; k < half.pairs.size(); ++k)
    if (start.pairs.mode[k] != half.pairs.mode[k] || full.pairs.mode[k] != half.pairs.mode[k])
      return false;
  for (std::size_t k = 0; k < half.walls.size(); ++k)
    if (start.walls.history[k].mode != half.walls.history[k].mode ||
        full.walls.history[k].mode != half.walls.history[k].mode)
      return false;
  return true;
}

/// Replaces the two-half-step result by the Richardson value y* = (2^p y2 - y1) / (2^p - 1) for the
/// whole island (partners never mix y* and y2, so momentum stays exact), then re-evaluates the
/// forces there without advancing the springs (h = 0).
void apply_richardson(IslandState& half, const IslandState& full, const broadphase::CandidatePairs& candidates,
                      const IslandPhysics& physics, IslandScratch& scratch) {
  const int order = 2;
  State& b = half.state;
  const State& a = full.state;
  for (std::size_t q = 0; q < b.size(); ++q) {
    if (b.inv_mass[q] == 0) continue;
    b.position[q] = richardson(a.position[q], b.position[q], order);
    b.velocity[q] = richardson(a.velocity[q], b.velocity[q], order);
    if (physics.kernels.uses_rotation) b.angular_velocity[q] = richardson(a.angular_velocity[q], b.angular_velocity[q], order);
    if (physics.dimension == 2) b.position[q].z() = 0, b.velocity[q].z() = 0;
  }
  evaluate_forces(half, candidates, physics, scratch, 0);
}

}  // namespace

void DoublingCounters::add(const DoublingCounters& o) {
  accepted += o.accepted;
  rejected += o.rejected;
  forced += o.forced;
  particle_steps += o.particle_steps;
  force_evaluations += o.force_evaluations;
  richardson += o.richardson;
  member_retries += o.member_retries;
  if (histogram.size() < o.histogram.size()) histogram.resize(o.histogram.size(), 0);
  for (std::size_t k = 0; k < o.histogram.size(); ++k) histogram[k] += o.histogram[k];
}

namespace {

Vec3 acceleration_of(const State& s, std::size_t q, const Vec3& gravity) {
  return s.inv_mass[q] == 0 ? Vec3(Vec3::Zero()) : Vec3(s.inv_mass[q] * s.force[q] + gravity);
}

}  // namespace

bool pair_may_close(const State& s, std::size_t a, std::size_t b, const Vec3& gravity, Real h) {
  if (s.inv_mass[a] == 0 && s.inv_mass[b] == 0) return false;
  const Real gap = (s.position[a] - s.position[b]).norm() - s.radius[a] - s.radius[b];
  if (gap <= 0) return false;  // in contact: the error control's business
  const Real closing = (s.velocity[a] - s.velocity[b]).norm() * h +
                       0.5 * (acceleration_of(s, a, gravity) - acceleration_of(s, b, gravity)).norm() * h * h;
  return 2 * closing > gap;
}

bool wall_may_close(const State& s, std::size_t a, const Walls& walls, std::size_t w, const Vec3& gravity, Real h) {
  if (s.inv_mass[a] == 0) return false;
  const Real closing = (s.velocity[a] - walls.velocity_at(w, s.position[a])).norm() * h +
                       0.5 * acceleration_of(s, a, gravity).norm() * h * h;
  // A filtered wall farther than that from the sphere has no feature within it: the common case,
  // decided without the features.
  if (!walls.may_touch(w, s.position[a], s.radius[a], 2 * closing)) return false;
  // A wall feature within twice the closing distance that is not touched yet (the features touched
  // at a radius are touched at any larger one, so a larger count means a new one).
  return walls.touching_count(w, s.position[a], s.radius[a] + 2 * closing) >
         walls.touching_count(w, s.position[a], s.radius[a]);
}

ClosingWalls::ClosingWalls(const State& s, const Walls& walls, const Vec3& gravity)
    : s_(s), walls_(walls), gravity_(gravity) {
  const bool any_filtered = [&] {
    for (std::size_t w = 0; w < walls.count(); ++w)
      if (walls.filtered(w)) return true;
    return false;
  }();
  if (s.size() == 0 || !any_filtered) return;
  // The particles' centres lie within `spread` of `middle`, so a wall turning at omega about c moves
  // its material at any of them by at most |v| + |omega| (|middle - c| + spread).
  Vec3 lo = s.position[0], hi = s.position[0];
  for (const Vec3& x : s.position) {
    if (!x.allFinite()) {
      wall_speed_ = std::numeric_limits<Real>::infinity();
      return;
    }
    lo = lo.cwiseMin(x), hi = hi.cwiseMax(x);
  }
  const Vec3 middle = 0.5 * (lo + hi);
  const Real spread = 0.5 * (hi - lo).norm();
  for (std::size_t w = 0; w < walls.count(); ++w) {
    if (!walls.filtered(w)) continue;  // may_touch is true for it
    const Vec3& c = walls.rotation_center(w);
    const Real speed =
        walls.velocity_at(w, c).norm() + walls.angular_velocity(w).norm() * ((middle - c).norm() + spread);
    if (!(speed <= wall_speed_)) wall_speed_ = speed;  // NaN carries through: every wall is then tested
  }
}

Real ClosingWalls::closing_bound(std::size_t a, Real h) const {
  return (1 + 1e-9) *
         ((s_.velocity[a].norm() + wall_speed_) * h + 0.5 * acceleration_of(s_, a, gravity_).norm() * h * h);
}

void watch_deepest_contact(IslandState& island, Real time) {
  merge_deepest(island, deepest_contact(island.state, island.pairs, island.walls), time);
}

int anticipation_level(const IslandState& island, const broadphase::CandidatePairs& candidates, const Walls& walls,
                       const Vec3& gravity, Real dt_base, int level, int contact_level) {
  const State& s = island.state;
  const ClosingWalls closing(s, walls, gravity);
  auto clear_at = [&](int l) {
    const Real h = std::ldexp(dt_base, l);
    for (std::size_t a = 0; a < s.size(); ++a) {
      for (std::uint32_t k = candidates.row_start[a]; k < candidates.row_start[a + 1]; ++k)
        if (pair_may_close(s, a, candidates.partner[k], gravity, h)) return false;
      if (!closing.for_each(a, h, [](std::size_t) { return false; })) return false;
    }
    return true;
  };
  for (int l = level; l > contact_level; --l)
    if (clear_at(l)) return l;
  return std::min(level, contact_level);
}

int advance_island(IslandState& island, const broadphase::CandidatePairs& candidates, const IslandPhysics& physics,
                   const DoublingSettings& settings, IslandScratch& scratch, Real t0, std::int64_t begin,
                   std::int64_t end, int level, DoublingCounters& counters) {
  const std::uint64_t n = island.state.size();
  const Real finest = std::ldexp(settings.dt_base, settings.level_min);
  const int order = physics.method == Method::exact ? 1 : 2;
  const Real bulge_per_h2 = physics.method == Method::exact ? physics.gravity.norm() / 8 : 0;
  const std::size_t levels = settings.level_max - settings.level_min + 1;
  if (counters.histogram.size() < levels) counters.histogram.resize(levels, 0);
  scratch.origin = island.state.position;
  island.excursion.assign(n, 0);
  std::int64_t tick = begin;
  level = std::clamp(level, settings.level_min, settings.level_max);
  while (tick < end) {
    // A step starts only where its level is aligned and ends inside the round.
    level = aligned_level(level, settings.level_min, tick, end);
    const Real t = t0 + static_cast<Real>(tick) * finest;
    if (physics.method == Method::verlet && level > settings.contact_level) {
      scratch.walls.set_time(t);
      level = anticipation_level(island, candidates, scratch.walls, physics.gravity, settings.dt_base, level,
                                 settings.contact_level);
    }
    for (;;) {
      const std::int64_t ticks = ticks_of_level(level, settings.level_min);
      const Real h = std::ldexp(settings.dt_base, level);
      IslandState& full = scratch.full;
      IslandState& half = scratch.half;
      full = island;
      half = island;
      std::uint64_t redone = step(full, candidates, physics, scratch, t, h);
      redone += step(half, candidates, physics, scratch, t, 0.5 * h);
      track_excursion(half, scratch.origin, bulge_per_h2 * 0.25 * h * h);
      redone += step(half, candidates, physics, scratch, t + 0.5 * h, 0.5 * h);
      track_excursion(half, scratch.origin, bulge_per_h2 * 0.25 * h * h);
      counters.particle_steps += 3 * n + redone;
      counters.force_evaluations += 3 * n + redone;
      counters.rejected += redone;
      const bool no_event = same_contacts(island, full, half);
      Real error = island_error(island, full, half, h, settings);
      // A smooth step's error budget is per unit step (it recurs all along the path); an event's is
      // one fixed amount (it happens once, and its error is only first order in h): the norm over
      // the reference time's displacement instead of the step's.
      if (!no_event) error = std::max(error, event_error(island, half, h, settings)) * (h / reference_time(settings, h));
      const bool aligned = (tick + ticks) % (2 * ticks) == 0;
      const LevelDecision d = decide_level(error, level, settings.level_min, settings.level_max, order,
                                           settings.safety, settings.tolerance, aligned);
      if (!d.accept) {
        counters.rejected += n;
        level = d.level;
        continue;
      }
      if (settings.richardson && physics.method == Method::verlet && std::isfinite(error) && no_event) {
        apply_richardson(half, full, candidates, physics, scratch);
        counters.force_evaluations += n;
        ++counters.richardson;
      }
      std::swap(island, half);
      // A round may be long enough for a particle to pass through a wall or partner whose law
      // cannot stop it (the exact stepper watches inside its steps).
      if (physics.method == Method::verlet) watch_deepest_contact(island, t + h);
      counters.accepted += n;
      if (d.forced) counters.forced += n;
      counters.histogram[level - settings.level_min] += n;
      tick += ticks;
      level = d.level;
      break;
    }
  }
  return level;
}

}  // namespace dem

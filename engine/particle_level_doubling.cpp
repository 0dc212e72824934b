#include "engine/particle_level_doubling.h"

#include <algorithm>
#include <cmath>

#include "engine/member_retry.h"
#include "engine/multilevel_stepper.h"
#include "engine/scheduler.h"
#include "engine/step_control.h"

namespace dem {
namespace {

/// A member's level is that of its full trial; the island keeps the half trial, one level finer. So
/// the highest level whose accepted step is at most `step`: one above the level of `step`, and
/// level_min when even that is below level_min (both trials then run at level_min).
int full_trial_level(Real step, const DoublingSettings& settings) {
  return level_of_step(step, settings.dt_base, settings.level_min - 1, settings.level_max - 1) + 1;
}

/// The island's contact adjacency for its pair and wall contacts.
void index_contacts(IslandState& island) {
  const std::size_t n = island.state.size();
  build_pair_adjacency(n, island.pairs, island.adjacency);
  std::vector<std::uint32_t>& start = island.adjacency.wall_start;
  start.assign(n + 1, 0);
  for (std::size_t k = 0; k < island.walls.size(); ++k) ++start[island.walls.particle[k] + 1];
  for (std::size_t p = 0; p < n; ++p) start[p + 1] += start[p];
}

/// The island's state after an accepted trial, its contacts and books; `origin` holds the members'
/// positions at the round's start, for their excursions.
void take_trial(const MultilevelGroup& trial, bool book_events, const std::vector<Vec3>& origin, IslandState& island) {
  State& s = island.state;
  const State& t = trial.state();
  for (std::size_t q = 0; q < s.size(); ++q)
    island.excursion[q] = std::max(island.excursion[q], (s.position[q] - origin[q]).norm() + trial.excursion()[q]);
  s.position = t.position;
  s.velocity = t.velocity;
  s.angular_velocity = t.angular_velocity;
  s.force = t.force;
  s.torque = t.torque;
  trial.pair_contacts(island.pairs);
  trial.wall_contacts(island.walls);
  index_contacts(island);
  island.ended_dissipation += trial.ended_dissipation();
  island.wall_work += trial.wall_work();
  if (book_events) island.events.append(trial.events());
}

/// The same from the half trial merged with a retry; each member's force and torque are gathered
/// from the merged contacts.
void take_retry(const MemberRetry& retry, const IslandPhysics& physics, const std::vector<Vec3>& origin,
                IslandState& island) {
  State& s = island.state;
  for (std::size_t q = 0; q < s.size(); ++q) {
    island.excursion[q] = std::max(island.excursion[q], (s.position[q] - origin[q]).norm() + retry.half_excursion(q));
    const TrialState end = retry.end(MemberRetry::Trial::half, q);
    s.position[q] = end.position;
    s.velocity[q] = end.velocity;
    s.angular_velocity[q] = end.angular_velocity;
  }
  retry.half_contacts(island.pairs, island.walls);
  index_contacts(island);
  gather_forces(s, island.pairs, island.walls, island.adjacency, physics.kernels.uses_rotation, physics.dimension);
  island.ended_dissipation += retry.half_ended_dissipation();
  island.wall_work += retry.half_wall_work();
  if (physics.book_events) retry.half_events(island.events);
}

/// Per member, the highest full-trial level whose accepted step keeps it stable on the springs it
/// touches now: an accepted step of at most sqrt(m / k), half velocity Verlet's limit 2 / omega, for
/// its mass m on the sum k of its contacts' normal stiffnesses (partners held fixed: a coarse member
/// moves under finer ones as if they were), so the full trial stays within the limit itself.
/// level_max without contacts; immovable members are not capped (they take the chunk's level).
void stability_levels(const IslandState& island, const MaterialTable& materials, const Walls& walls,
                      const DoublingSettings& settings, std::vector<int>& level) {
  const State& s = island.state;
  std::vector<Real> stiffness(s.size(), 0);
  const PairContacts& pairs = island.pairs;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const Real k_n = materials.params(materials.pair_class(s.material[pairs.i[k]], s.material[pairs.j[k]])).k_n;
    stiffness[pairs.i[k]] += k_n;
    stiffness[pairs.j[k]] += k_n;
  }
  const WallContacts& wc = island.walls;
  for (std::size_t k = 0; k < wc.size(); ++k) {
    const ParticleIndex p = wc.particle[k];
    stiffness[p] += materials.params(materials.pair_class(s.material[p], walls.material(wc.wall[k]))).k_n;
  }
  for (std::size_t q = 0; q < s.size(); ++q) {
    level[q] = settings.level_max;
    if (s.inv_mass[q] == 0 || stiffness[q] <= 0) continue;
    level[q] = full_trial_level(std::sqrt(1 / (s.inv_mass[q] * stiffness[q])), settings);
  }
}

}  // namespace

int chunk_level_bound(const std::vector<int>& levels, const std::vector<Real>& inv_mass, int highest) {
  std::vector<int> movable;
  for (std::size_t q = 0; q < levels.size(); ++q)
    if (inv_mass[q] != 0) movable.push_back(levels[q]);
  if (movable.empty()) return highest;
  // The level of the member at the chunk_level_share quantile, counted from the finest.
  const auto at = static_cast<std::size_t>(std::ceil(chunk_level_share * static_cast<Real>(movable.size()))) - 1;
  std::nth_element(movable.begin(), movable.begin() + static_cast<std::ptrdiff_t>(at), movable.end());
  return std::min(highest, movable[at]);
}

void anticipate_per_pair(const State& s, const broadphase::CandidatePairs& candidates, const MaterialTable& materials,
                         const Walls& walls, const Vec3& gravity, const DoublingSettings& settings, int chunk_level,
                         std::vector<int>& levels) {
  const Real h = std::ldexp(settings.dt_base, chunk_level);
  const auto resolving = [&](std::uint16_t pair_class, Real inv_m) {
    return full_trial_level(contact_resolving_step(materials.params(pair_class).k_n, inv_m), settings);
  };
  const ClosingWalls closing(s, walls, gravity);
  for (std::size_t a = 0; a < s.size(); ++a) {
    for (std::uint32_t k = candidates.row_start[a]; k < candidates.row_start[a + 1]; ++k) {
      const std::size_t b = candidates.partner[k];
      if (!pair_may_close(s, a, b, gravity, h)) continue;
      const int level = resolving(materials.pair_class(s.material[a], s.material[b]), s.inv_mass[a] + s.inv_mass[b]);
      levels[a] = std::min(levels[a], level);
      levels[b] = std::min(levels[b], level);
    }
    closing.for_each(a, h, [&](std::size_t w) {
      levels[a] = std::min(levels[a], resolving(materials.pair_class(s.material[a], walls.material(w)), s.inv_mass[a]));
      return true;
    });
  }
}

void advance_island_per_particle(IslandState& island, const broadphase::CandidatePairs& candidates,
                                 const IslandPhysics& physics, const DoublingSettings& settings, IslandScratch& scratch,
                                 Real t0,
                                 std::int64_t begin, std::int64_t end, std::vector<int>& levels,
                                 DoublingCounters& counters) {
  const std::size_t n = island.state.size();
  Walls& walls = scratch.walls;
  MultilevelGroup& full = scratch.levels_full;
  MultilevelGroup& half = scratch.levels_half;
  const int level_min = settings.level_min;
  const Real finest = std::ldexp(settings.dt_base, level_min);
  const std::size_t level_count = static_cast<std::size_t>(settings.level_max - level_min + 1);
  if (counters.histogram.size() < level_count) counters.histogram.resize(level_count, 0);
  MultilevelPhysics mp;
  mp.materials = physics.materials;
  mp.kernels = physics.kernels;
  mp.gravity = physics.gravity;
  mp.dimension = physics.dimension;
  mp.dt_base = settings.dt_base;
  mp.level_min = level_min;
  mp.walls_move = physics.walls_move;
  mp.book_events = physics.book_events;
  mp.wall_margin = physics.wall_margin;
  const std::vector<Vec3> origin = island.state.position;
  // The island's wall lists, made once for the round: every trial's levels select theirs from them.
  const bool wall_lists = physics.wall_margin > 0 && walls.count() > 0;
  if (wall_lists) {
    walls.set_time(t0 + static_cast<Real>(begin) * finest);
    scratch.wall_lists.build(island.state, walls, physics.wall_margin);
  }
  full.take_wall_lists_from(wall_lists ? &scratch.wall_lists : nullptr);
  half.take_wall_lists_from(wall_lists ? &scratch.wall_lists : nullptr);
  island.excursion.assign(n, 0);
  island.events.clear();
  std::vector<int> halves(n);
  std::vector<LevelDecision> decision(n);
  std::vector<Real> errors(n);
  std::vector<std::uint8_t> failed(n);
  std::vector<int> stability(n);
  std::vector<std::uint8_t> live(n);  // per chunk: the members its next try redoes
  // Chunk by chunk: a chunk is one step of the island's coarsest member (the few coarsest aside,
  // below), so levels change (and promote) at every chunk, not once per round.
  for (std::int64_t tick = begin; tick < end;) {
    // Each member's step starts here on its own grid and ends within the round. The chunk is the
    // longest step of a movable member but for a few (chunk_level_bound); an immovable one takes the
    // chunk's level, below.
    const auto movable = [&](std::size_t q) { return island.state.inv_mass[q] != 0; };
    const auto coarsest = [&] {
      int highest = level_min, any = level_min;
      for (std::size_t q = 0; q < n; ++q) {
        any = std::max(any, levels[q]);
        if (movable(q)) highest = std::max(highest, levels[q]);
      }
      return std::any_of(island.state.inv_mass.begin(), island.state.inv_mass.end(), [](Real w) { return w != 0; })
                 ? highest
                 : any;
    };
    for (int& l : levels) l = aligned_level(std::clamp(l, level_min, settings.level_max), level_min, tick, end);
    int highest = coarsest();
    const Real t = t0 + static_cast<Real>(tick) * finest;
    // No member of an approaching pair accepted above the level that resolves its contact, and none
    // above the level that keeps it stable on the springs it touches. No pair's cap lies below the
    // full trial of contact_level, which resolves the stiffest, lightest pair (at level_min, that
    // level may have been clamped: then caps may reach level_min itself).
    walls.set_time(t);
    const int uncapped = settings.contact_level > level_min ? std::min(settings.contact_level + 1, settings.level_max)
                                                            : level_min;
    if (highest > uncapped)
      anticipate_per_pair(island.state, candidates, *physics.materials, walls, physics.gravity, settings, highest,
                          levels);
    stability_levels(island, *physics.materials, walls, settings, stability);
    for (std::size_t q = 0; q < n; ++q) levels[q] = std::min(levels[q], stability[q]);
    highest = coarsest();
    // A few coarse members do not set the chunk: those above chunk_level_bound step at it.
    highest = chunk_level_bound(levels, island.state.inv_mass, highest);
    for (int& l : levels) l = std::min(l, highest);
    // An immovable member's prediction is its path: it takes the longest step, and its contacts the
    // levels of its partners.
    for (std::size_t q = 0; q < n; ++q)
      if (!movable(q)) levels[q] = highest;
    const std::int64_t ticks = ticks_of_level(highest, level_min);
    const Real chunk = static_cast<Real>(ticks) * finest;
    // The time over which a member's error is weighed (step_control.h): the run's reference time,
    // else the member's own step, so that a member taking many steps in the chunk is held to the
    // error per step that one level per island holds it to, not to that much over the whole chunk.
    const auto reference_time = [&](std::size_t q) {
      return settings.reference_time > 0 ? settings.reference_time : std::ldexp(settings.dt_base, levels[q]);
    };
    const State& start = island.state;
    MemberRetry& retry = scratch.retry;
    retry.clear();
    live.assign(n, 0);
    for (;;) {
      for (std::size_t q = 0; q < n; ++q) halves[q] = std::max(levels[q] - 1, level_min);
      std::uint64_t steps = 0;
      if (std::find(live.begin(), live.end(), 1) != live.end()) {
        retry.redo(start, island.pairs, island.walls, candidates, walls, mp, t, ticks, live, levels, halves, full,
                   half);
        steps = retry.particle_steps();
        ++counters.member_retries;
      } else {
        full.reset(start, candidates, walls, mp, t, levels, island.pairs, island.walls);
        full.advance(ticks);
        half.reset(start, candidates, walls, mp, t, halves, island.pairs, island.walls);
        half.advance(ticks);
        steps = full.particle_steps() + half.particle_steps();
      }
      counters.particle_steps += steps;
      counters.force_evaluations += steps;
      // Each member's ends of the two trials, merged with a retry's.
      const auto end_of = [&](MemberRetry::Trial trial, std::size_t q) -> TrialState {
        if (retry.active()) return retry.end(trial, q);
        const State& r = trial == MemberRetry::Trial::full ? full.state() : half.state();
        return {r.position[q], r.velocity[q], r.angular_velocity[q]};
      };
      bool accepted = true;
      for (std::size_t q = 0; q < n; ++q) {
        failed[q] = 0;
        if (start.inv_mass[q] == 0) {
          decision[q] = {true, false, levels[q]};
          continue;
        }
        const TrialState one = end_of(MemberRetry::Trial::full, q);
        const TrialState two = end_of(MemberRetry::Trial::half, q);
        errors[q] = step_error(one, two, two.position - start.position[q], chunk, reference_time(q), start.radius[q],
                               settings.velocity_weight, settings.dx_min);
      }
      // A coarse member stands in for its finer partners as its prediction: where that missed its
      // booked path by more than a finer partner's error budget, the coarse member is at fault (its
      // own displacement may be tiny: a heavy ball under light ones).
      const std::vector<std::pair<ParticleIndex, ParticleIndex>> touching =
          retry.active() ? retry.touching_pairs() : full.touching_pairs();
      const auto miss_of = [&](std::size_t q) { return retry.active() ? retry.miss(q) : full.prediction_miss()[q]; };
      const auto check_miss = [&](std::size_t coarse, std::size_t fine, int level, Real miss) {
        if (start.inv_mass[coarse] == 0 || start.inv_mass[fine] == 0) return;
        // The finer partner's budget over one step of the coarse member (the miss is its largest over one).
        const Real coarse_step = std::ldexp(settings.dt_base, level);
        const Real budget = (end_of(MemberRetry::Trial::half, fine).position - start.position[fine]).norm() *
                                (coarse_step / chunk) +
                            settings.dx_min * start.radius[fine] * coarse_step / reference_time(fine);
        const Real error = miss / budget;
        if (!(error <= errors[coarse])) errors[coarse] = error;
      };
      for (const auto& [a, b] : touching) {
        if (levels[a] > levels[b]) check_miss(a, b, levels[a], miss_of(a));
        if (levels[b] > levels[a]) check_miss(b, a, levels[b], miss_of(b));
      }
      for (std::size_t q = 0; q < n; ++q) {
        if (start.inv_mass[q] == 0) continue;
        const bool aligned = (tick + ticks) % (2 * ticks_of_level(levels[q], level_min)) == 0;
        decision[q] = decide_level(errors[q], levels[q], level_min, settings.level_max, 2, settings.safety,
                                   settings.tolerance, aligned);
        // No promotion to the stability cap: there the full trial reaches velocity Verlet's limit, its
        // error grows much faster than the 2^p a promotion assumes, and most such promotions failed,
        // each failure a retry. A member may still reach the cap from above.
        if (decision[q].level > levels[q] && decision[q].level >= stability[q]) decision[q].level = levels[q];
        failed[q] = !decision[q].accept;
      }
      // A member accepted only because it reached level_min fails while a touching partner is coarser:
      // its error may be that partner's.
      for (const auto& [i, j] : touching)
        for (const auto& [q, p] : {std::pair{i, j}, std::pair{j, i}})
          if (decision[q].forced && levels[p] > levels[q] && start.inv_mass[p] != 0) failed[q] = 1;
      for (std::size_t q = 0; q < n; ++q) accepted = accepted && !failed[q];
      if (!accepted) {
        // A failed member drops its levels, and its touching partners above its new level drop as many
        // (at least one, not below its new level): a squeezed particle's error is partly its partners',
        // and halving it alone would not shrink that part.
        std::vector<int> next = levels;
        for (std::size_t q = 0; q < n; ++q)
          if (failed[q]) next[q] = decision[q].level;
        for (const auto& [i, j] : touching)
          for (const auto& [q, p] : {std::pair{i, j}, std::pair{j, i}}) {
            if (!failed[q] || levels[p] <= decision[q].level || start.inv_mass[p] == 0) continue;
            const int drop = std::max(1, levels[q] - decision[q].level);
            next[p] = std::min(next[p], std::max(decision[q].level, levels[p] - drop));
          }
        // The next try redoes the failed members, every touching partner of one and whatever an
        // earlier try of this chunk redid; the whole island when that is most of it, or when the
        // first try did not record its steps for a replay.
        for (std::size_t q = 0; q < n; ++q)
          if (failed[q]) live[q] = 1;
        for (const auto& [i, j] : touching)
          if (failed[i] || failed[j]) live[i] = live[j] = 1;
        for (std::size_t q = 0; q < n; ++q)
          if (next[q] != levels[q]) live[q] = 1;
        const bool whole = 2 * static_cast<std::size_t>(std::count(live.begin(), live.end(), 1)) > n ||
                           !full.steps_recorded() || !half.steps_recorded();
        // Rejected: the steps of this try's members that the next one redoes.
        for (std::size_t q = 0; q < n; ++q)
          if (whole || live[q])
            counters.rejected += static_cast<std::uint64_t>(ticks / ticks_of_level(levels[q], level_min) +
                                                            ticks / ticks_of_level(halves[q], level_min));
        if (whole) {
          std::fill(live.begin(), live.end(), 0);
          retry.clear();
        }
        levels = next;
        continue;
      }
      for (std::size_t q = 0; q < n; ++q) {
        const std::uint64_t own = static_cast<std::uint64_t>(ticks / ticks_of_level(halves[q], level_min));
        counters.accepted += own;
        counters.histogram[halves[q] - level_min] += own;
        if (decision[q].forced) counters.forced += own;
        levels[q] = decision[q].level;
      }
      if (retry.active())
        take_retry(retry, physics, origin, island);
      else
        take_trial(half, physics.book_events, origin, island);
      watch_deepest_contact(island, t + chunk);
      break;
    }
    tick += ticks;
  }
}

}  // namespace dem

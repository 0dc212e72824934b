#include "engine/member_retry.h"

#include <algorithm>

#include "engine/checks.h"
#include "engine/memory_usage.h"

namespace dem {

void MemberRetry::redo(const State& start, const PairContacts& pairs, const WallContacts& wall_contacts,
                       const broadphase::CandidatePairs& candidates, Walls& walls, const MultilevelPhysics& physics,
                       Real time, std::int64_t ticks, const std::vector<std::uint8_t>& live,
                       const std::vector<int>& levels, const std::vector<int>& halves,
                       const MultilevelGroup& first_full, const MultilevelGroup& first_half) {
  const std::size_t n = start.size();
  DEM_ASSERT(live.size() == n && candidates.row_count() == n);
  active_ = true;
  start_ = &start;
  live_ = live;
  // The group: the live members and every candidate or contact partner of one (the border).
  sub_of_.assign(n, outside);
  for (std::size_t q = 0; q < n; ++q)
    if (live[q]) sub_of_[q] = 0;
  for (std::size_t a = 0; a < n; ++a)
    for (std::uint32_t k = candidates.row_start[a]; k < candidates.row_start[a + 1]; ++k) {
      const std::size_t b = candidates.partner[k];
      if (live[a] || live[b]) sub_of_[a] = sub_of_[b] = 0;
    }
  for (std::size_t k = 0; k < pairs.size(); ++k)  // a contact that is no longer a candidate ends in the group
    if (live[pairs.i[k]] || live[pairs.j[k]]) sub_of_[pairs.i[k]] = sub_of_[pairs.j[k]] = 0;
  group_.clear();
  for (std::size_t q = 0; q < n; ++q)
    if (sub_of_[q] != outside) {
      sub_of_[q] = static_cast<std::uint32_t>(group_.size());
      group_.push_back(static_cast<ParticleIndex>(q));
    }
  const std::size_t m = group_.size();
  select_particles(start, group_, sub_state_);
  // Candidates with a live side (two border members' contact stays as the first try left it).
  sub_candidates_.row_start.assign(m + 1, 0);
  sub_candidates_.partner.clear();
  for (std::size_t s = 0; s < m; ++s) {
    const std::size_t a = group_[s];
    for (std::uint32_t k = candidates.row_start[a]; k < candidates.row_start[a + 1]; ++k) {
      const std::size_t b = candidates.partner[k];
      if (live[a] || live[b]) sub_candidates_.partner.push_back(sub_of_[b]);
    }
    sub_candidates_.row_start[s + 1] = static_cast<std::uint32_t>(sub_candidates_.partner.size());
  }
  // The start contacts with a live side, and the live members' wall contacts, in group slots.
  sub_pairs_.parts = pairs.parts;
  sub_pairs_.resize(0);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    if (!live[pairs.i[k]] && !live[pairs.j[k]]) continue;
    const std::size_t at = sub_pairs_.size();
    sub_pairs_.resize(at + 1);
    copy_pair(pairs, k, sub_pairs_, at);
    sub_pairs_.i[at] = sub_of_[pairs.i[k]];
    sub_pairs_.j[at] = sub_of_[pairs.j[k]];
  }
  sub_pairs_.index_rows(m);
  sub_walls_.resize(0);
  for (std::size_t k = 0; k < wall_contacts.size(); ++k) {
    if (!live[wall_contacts.particle[k]]) continue;
    const std::size_t at = sub_walls_.size();
    sub_walls_.resize(at + 1);
    copy_wall(wall_contacts, k, sub_walls_, at);
    sub_walls_.particle[at] = sub_of_[wall_contacts.particle[k]];
  }
  run(trial_[0], levels, first_full, walls, physics, time, ticks);
  run(trial_[1], halves, first_half, walls, physics, time, ticks);
}

void MemberRetry::run(TrialRetry& trial, const std::vector<int>& levels, const MultilevelGroup& first, Walls& walls,
                      const MultilevelPhysics& physics, Real time, std::int64_t ticks) {
  const std::size_t m = group_.size();
  trial.first = &first;
  sub_levels_.resize(m);
  trial.replayed.assign(m, ReplayedPath{});
  const State& ends = first.state();
  for (std::size_t s = 0; s < m; ++s) {
    const std::size_t q = group_[s];
    sub_levels_[s] = levels[q];
    if (live_[q]) continue;
    DEM_ASSERT(first.level(q) == levels[q]);  // a border member keeps its first-try steps
    ReplayedPath& path = trial.replayed[s];
    path.steps = first.step_records().data() + first.record_start(q);
    path.end_position = ends.position[q];
    path.end_velocity = ends.velocity[q];
    path.end_spin = ends.angular_velocity[q];
  }
  trial.group.take_wall_lists_from(first.wall_lists_source(), &group_);
  trial.group.reset(sub_state_, sub_candidates_, walls, physics, time, sub_levels_, sub_pairs_, sub_walls_,
                    &trial.replayed, false);
  trial.group.advance(ticks);

  // Each border member gets what its live partners gave it now, less what they gave it in the first
  // try: the new contacts all have a live side, and the first try's are picked by theirs.
  std::vector<Vec3> impulse(m, Vec3::Zero()), moment(m, Vec3::Zero()), angular(m, Vec3::Zero());
  const auto book = [&](std::size_t s_i, std::size_t s_j, const ContactImpulse& c, Real sign) {
    if (!live_[group_[s_i]]) {
      impulse[s_i] += sign * c.impulse, moment[s_i] += sign * c.moment, angular[s_i] += sign * c.angular_i;
    }
    if (!live_[group_[s_j]]) {
      impulse[s_j] -= sign * c.impulse, moment[s_j] -= sign * c.moment, angular[s_j] += sign * c.angular_j;
    }
  };
  for (const ContactImpulse& c : trial.group.contact_impulses()) book(c.i, c.j, c, 1);
  for (const ContactImpulse& c : first.contact_impulses())
    if (live_[c.i] != live_[c.j]) book(sub_of_[c.i], sub_of_[c.j], c, -1);
  trial.shift.assign(m, Vec3::Zero());
  trial.kick.assign(m, Vec3::Zero());
  trial.spin_kick.assign(m, Vec3::Zero());
  for (std::size_t s = 0; s < m; ++s) {
    if (live_[group_[s]] || sub_state_.inv_mass[s] == 0) continue;
    const Real inv_m = sub_state_.inv_mass[s];
    trial.shift[s] = inv_m * moment[s];
    trial.kick[s] = inv_m * impulse[s];
    trial.spin_kick[s] = sub_state_.inv_inertia[s] * angular[s];
    if (physics.dimension == 2) {
      trial.shift[s].z() = 0, trial.kick[s].z() = 0;
      trial.spin_kick[s].x() = 0, trial.spin_kick[s].y() = 0;
    }
    if (!physics.kernels.uses_rotation) trial.spin_kick[s].setZero();
  }
}

TrialState MemberRetry::end(Trial trial, std::size_t q) const {
  const TrialRetry& retried = of(trial);
  const std::uint32_t s = active_ ? sub_of_[q] : outside;
  if (s != outside && live_[q]) {
    const State& r = retried.group.state();
    return {r.position[s], r.velocity[s], r.angular_velocity[s]};
  }
  const State& f = retried.first->state();
  TrialState out{f.position[q], f.velocity[q], f.angular_velocity[q]};
  if (s != outside) {
    out.position += retried.shift[s];
    out.velocity += retried.kick[s];
    out.angular_velocity += retried.spin_kick[s];
  }
  return out;
}

Real MemberRetry::miss(std::size_t q) const {
  const TrialRetry& retried = of(Trial::full);
  const std::uint32_t s = sub_of_[q];
  if (s != outside && live_[q]) return retried.group.prediction_miss()[s];
  const Real first = retried.first->prediction_miss()[q];
  return s == outside ? first : first + retried.shift[s].norm();
}

std::vector<std::pair<ParticleIndex, ParticleIndex>> MemberRetry::touching_pairs() const {
  std::vector<std::pair<ParticleIndex, ParticleIndex>> out;
  for (const auto& [a, b] : of(Trial::full).first->touching_pairs())
    if (!live_[a] && !live_[b]) out.emplace_back(a, b);
  for (const auto& [a, b] : of(Trial::full).group.touching_pairs()) out.emplace_back(group_[a], group_[b]);
  return out;
}

namespace {

/// The slots of `first` that `keep` accepts and every slot of `again`, in key order (both lists
/// ascend in key, and no kept key is in `again`): each as (from `again`, slot).
template <class List, class Keep>
std::vector<std::pair<bool, std::uint32_t>> merge_by_key(const List& first, Keep keep, const List& again) {
  DEM_VALIDATE(std::is_sorted(first.key.begin(), first.key.end()) && std::is_sorted(again.key.begin(), again.key.end()));
  std::vector<std::pair<bool, std::uint32_t>> order;
  order.reserve(first.size() + again.size());
  std::uint32_t a = 0;
  const auto again_size = static_cast<std::uint32_t>(again.size());
  for (std::uint32_t k = 0; k < first.size(); ++k) {
    if (!keep(k)) continue;
    for (; a < again_size && again.key[a] < first.key[k]; ++a) order.push_back({true, a});
    order.push_back({false, k});
  }
  for (; a < again_size; ++a) order.push_back({true, a});
  return order;
}

}  // namespace

void MemberRetry::half_contacts(PairContacts& pairs, WallContacts& wall_contacts) const {
  const TrialRetry& retried = of(Trial::half);
  // The first try's contacts without a live side and the retry's, merged in key order.
  const PairContacts first = retried.first->pair_contacts();
  const PairContacts again = retried.group.pair_contacts();
  const auto order =
      merge_by_key(first, [&](std::uint32_t k) { return !live_[first.i[k]] && !live_[first.j[k]]; }, again);
  pairs.parts = first.parts;
  pairs.resize(order.size());
  for (std::size_t q = 0; q < order.size(); ++q) {
    const auto [from_retry, k] = order[q];
    copy_pair(from_retry ? again : first, k, pairs, q);
    if (from_retry) pairs.i[q] = group_[again.i[k]], pairs.j[q] = group_[again.j[k]];
  }
  pairs.index_rows(live_.size());

  const WallContacts first_walls = retried.first->wall_contacts();
  const WallContacts again_walls = retried.group.wall_contacts();
  const auto wall_order =
      merge_by_key(first_walls, [&](std::uint32_t k) { return !live_[first_walls.particle[k]]; }, again_walls);
  wall_contacts.resize(wall_order.size());
  for (std::size_t q = 0; q < wall_order.size(); ++q) {
    const auto [from_retry, k] = wall_order[q];
    copy_wall(from_retry ? again_walls : first_walls, k, wall_contacts, q);
    if (from_retry) wall_contacts.particle[q] = group_[again_walls.particle[k]];
  }
}

bool MemberRetry::id_is_live(ParticleId id) const {
  const std::vector<ParticleId>& ids = start_->id;
  const auto at = std::lower_bound(ids.begin(), ids.end(), id);
  DEM_ASSERT(at != ids.end() && *at == id);
  return live_[static_cast<std::size_t>(at - ids.begin())] != 0;
}

bool MemberRetry::key_is_live(std::uint64_t key, bool wall) const {
  const ParticleId high = static_cast<ParticleId>(key >> 32);
  return id_is_live(high) || (!wall && id_is_live(static_cast<ParticleId>(key)));
}

Real MemberRetry::half_ended_dissipation() const {
  const TrialRetry& retried = of(Trial::half);
  Real replaced = 0;
  for (const EndedContact& e : retried.first->ended_contacts())
    if (key_is_live(e.key, e.wall)) replaced += e.dissipated;
  return retried.first->ended_dissipation() - replaced + retried.group.ended_dissipation();
}

Real MemberRetry::half_wall_work() const {
  const TrialRetry& retried = of(Trial::half);
  Real replaced = 0;
  const std::vector<Real>& work = retried.first->particle_wall_work();
  for (std::size_t q = 0; q < live_.size(); ++q)
    if (live_[q]) replaced += work[q];
  return retried.first->wall_work() - replaced + retried.group.wall_work();
}

void MemberRetry::half_events(ContactEvents& out) const {
  const TrialRetry& retried = of(Trial::half);
  for (const ContactEvents::Event& e : retried.first->events().events())
    if (!key_is_live(e.key, e.wall)) out.add(e);
  out.append(retried.group.events());
}

Real MemberRetry::half_excursion(std::size_t q) const {
  const TrialRetry& retried = of(Trial::half);
  const std::uint32_t s = sub_of_[q];
  if (s != outside && live_[q]) return retried.group.excursion()[s];
  const Real first = retried.first->excursion()[q];
  return s == outside ? first : first + retried.shift[s].norm();
}

std::size_t MemberRetry::memory_bytes() const {
  std::size_t total = heap_bytes(live_) + heap_bytes(group_) + heap_bytes(sub_of_) + heap_bytes(sub_state_) +
                      heap_bytes(sub_candidates_) + heap_bytes(sub_pairs_) + heap_bytes(sub_walls_) +
                      heap_bytes(sub_levels_);
  for (const TrialRetry& r : trial_)
    total += r.group.memory_bytes() + heap_bytes(r.replayed) + heap_bytes(r.shift) + heap_bytes(r.kick) +
             heap_bytes(r.spin_kick);
  return total;
}

}  // namespace dem

#include "engine/multilevel_stepper.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "engine/checks.h"
#include "engine/memory_usage.h"

namespace dem {
namespace {

/// Makes `v` hold `count` elements, keeping the storage of those it already held.
template <class T>
void resize_keeping(std::vector<T>& v, std::size_t count) {
  if (v.size() < count) v.resize(count);
  v.erase(v.begin() + static_cast<std::ptrdiff_t>(count), v.end());
}

void flatten_to_plane(Vec3& v) { v.z() = 0; }
void spin_about_normal(Vec3& w) { w.x() = 0, w.y() = 0; }

constexpr std::uint32_t no_impulse = 0xffffffffu;  // a slot that has not touched in this advance
constexpr std::uint64_t max_records_per_particle = 32;  // steps kept for a retry, on average

/// A contact of one per-level list, by key: its level index, its slot in that list and the slot's row.
struct KeyedSlot {
  std::uint64_t key = 0;
  std::uint32_t level = 0, slot = 0, row = 0;
  bool operator<(const KeyedSlot& other) const { return key < other.key; }
};

/// Sorts `order`, made of runs order[bounds[r] .. bounds[r + 1]] (one per level), each of which
/// usually ascends already (a level's list is in key order while slots follow ids): a run that does
/// not is sorted, and the runs are merged. Keys are unique, so this is std::sort's order.
void sort_level_runs(std::vector<KeyedSlot>& order, const std::vector<std::size_t>& bounds) {
  const auto at = [&](std::size_t r) { return order.begin() + static_cast<std::ptrdiff_t>(bounds[r]); };
  for (std::size_t r = 0; r + 1 < bounds.size(); ++r)
    if (!std::is_sorted(at(r), at(r + 1))) std::sort(at(r), at(r + 1));
  for (std::size_t r = 1; r + 1 < bounds.size(); ++r) std::inplace_merge(at(0), at(r), at(r + 1));
}

}  // namespace

MultilevelGroup::MultilevelGroup(State state, broadphase::CandidatePairs candidates, Walls& walls,
                                 const MultilevelPhysics& physics, Real time, const std::vector<int>& levels,
                                 const PairContacts& pairs, const WallContacts& wall_contacts) {
  reset(state, candidates, walls, physics, time, levels, pairs, wall_contacts);
}

void MultilevelGroup::reset(const State& state, const broadphase::CandidatePairs& candidates, Walls& walls,
                            const MultilevelPhysics& physics, Real time, const std::vector<int>& levels,
                            const PairContacts& pairs, const WallContacts& wall_contacts,
                            const std::vector<ReplayedPath>* replay, bool record) {
  physics_ = physics;
  recording_ = record;
  tick_ = std::ldexp(physics_.dt_base, physics_.level_min);
  state_ = state;
  candidates_ = candidates;
  walls_ = &walls;
  time_ = time0_ = time;
  tick_origin_ = 0;
  ended_dissipation_ = 0;
  wall_work_ = 0;
  events_.clear();
  particle_steps_ = 0;
  ended_log_.clear();
  particle_wall_work_.assign(state.size(), 0);
  if (replay) {
    DEM_ASSERT(replay->size() == state.size());
    replayed_ = *replay;
  } else {
    replayed_.clear();
  }
  DEM_ASSERT(candidates_.row_count() == state_.size());
  rotation_ = physics_.kernels.uses_rotation;
  parts_ = {physics_.materials->any_friction(), physics_.materials->any_rolling(), physics_.book_events};
  check_levels(levels);
  level_ = levels;
  for (std::size_t p = 0; p < state_.size(); ++p) state_.level[p] = static_cast<std::int8_t>(levels[p]);
  distribute(pairs, wall_contacts);
  view_ = state_;
  origin_ = state_.position;
  excursion_.assign(state_.size(), 0);
  miss_.assign(state_.size(), 0);
}

MultilevelGroup::MultilevelGroup(State state, broadphase::CandidatePairs candidates, Walls& walls,
                                 const MultilevelPhysics& physics, Real time, const std::vector<int>& levels)
    : MultilevelGroup(std::move(state), std::move(candidates), walls, physics, time, levels, PairContacts{},
                      WallContacts{}) {
  // The first evaluation: every contact at the state as given, springs not advanced.
  walls_->set_time(time_);
  for (std::size_t c = 0; c < neighbours_.size(); ++c) evaluate_level(c, 0);
}

Real MultilevelGroup::step_of_index(std::size_t index) const { return level_step_[index]; }

Real MultilevelGroup::tick_length() const { return tick_; }

void MultilevelGroup::check_levels(const std::vector<int>& levels) const {
  if (levels.size() != state_.size()) throw std::invalid_argument("MultilevelGroup: one level per particle");
  for (int l : levels)
    if (l < physics_.level_min || l > physics_.level_min + 40)
      throw std::invalid_argument("MultilevelGroup: levels must lie in [level_min, level_min + 40]");
}

void MultilevelGroup::set_levels(const std::vector<int>& levels) {
  check_levels(levels);
  const PairContacts pairs = pair_contacts();
  const WallContacts walls = wall_contacts();
  level_ = levels;
  for (std::size_t p = 0; p < state_.size(); ++p) state_.level[p] = static_cast<std::int8_t>(levels[p]);
  distribute(pairs, walls);
}

void MultilevelGroup::distribute(const PairContacts& pairs, const WallContacts& wall_contacts) {
  const std::size_t n = state_.size();
  base_level_ = level_.empty() ? physics_.level_min : *std::min_element(level_.begin(), level_.end());
  std::size_t count = 1;
  for (int l : level_) count = std::max(count, level_index(l) + 1);
  level_step_.resize(count);
  for (std::size_t c = 0; c < count; ++c)
    level_step_[c] = std::ldexp(physics_.dt_base, base_level_ + static_cast<int>(c));
  const auto contact_index = [&](std::size_t a, std::size_t b) {
    return level_index(std::min(level_[a], level_[b]));
  };
  // Every per-level vector keeps the storage it had (a scratch group is reset chunk after chunk).
  resize_keeping(level_candidates_, count);
  resize_keeping(neighbours_, count);
  resize_keeping(compact_, count);
  resize_keeping(rows_, count);
  resize_keeping(participants_, count);
  resize_keeping(members_, count);
  resize_keeping(wall_members_, count);
  resize_keeping(wall_contacts_, count);
  resize_keeping(member_state_, count);
  resize_keeping(wall_start_, count);
  resize_keeping(wall_lists_, count);

  // Candidate pairs by contact level.
  for (broadphase::CandidatePairs& c : level_candidates_) c.row_start.assign(n + 1, 0);
  for (std::size_t a = 0; a < n; ++a)
    for (std::uint32_t k = candidates_.row_start[a]; k < candidates_.row_start[a + 1]; ++k)
      ++level_candidates_[contact_index(a, candidates_.partner[k])].row_start[a + 1];
  for (broadphase::CandidatePairs& c : level_candidates_) {
    for (std::size_t a = 0; a < n; ++a) c.row_start[a + 1] += c.row_start[a];
    c.partner.resize(c.row_start[n]);
  }
  // Rows are filled in order, so each level's cursor runs through its rows without a reset.
  fill_.assign(count, 0);
  for (std::size_t a = 0; a < n; ++a) {
    for (std::uint32_t k = candidates_.row_start[a]; k < candidates_.row_start[a + 1]; ++k) {
      const std::uint32_t b = candidates_.partner[k];
      const std::size_t c = contact_index(a, b);
      level_candidates_[c].partner[fill_[c]++] = b;
    }
  }

  // Each contact goes to the compact list of its contact level, in key order, and the persistent
  // lists are made from those.
  // Counted first, so each list is sized once.
  fill_.assign(count, 0);
  for (std::size_t k = 0; k < pairs.size(); ++k) ++fill_[contact_index(pairs.i[k], pairs.j[k])];
  for (std::size_t c = 0; c < count; ++c) {
    compact_[c].parts = parts_;
    compact_[c].resize(fill_[c]);
  }
  fill_.assign(count, 0);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const std::size_t c = contact_index(pairs.i[k], pairs.j[k]);
    copy_pair(pairs, k, compact_[c], fill_[c]++);
  }
  for (std::size_t c = 0; c < count; ++c) {
    compact_[c].index_rows(n);
    neighbours_[c].visited_rows.clear();
    rebuild_neighbours(state_, level_candidates_[c], compact_[c], neighbours_[c]);
  }
  // The lists the persistent ones were rebuilt from: what finish_ended_contacts reads for contacts
  // left behind. Swapped, so both keep their storage.
  resize_keeping(rebuilt_from_, count);
  for (std::size_t c = 0; c < count; ++c) std::swap(rebuilt_from_[c], compact_[c]);
  // Per contact level: the rows that hold its pairs, and the coarser particles in them.
  seen_.resize(n);
  for (std::size_t c = 0; c < count; ++c) {
    const broadphase::CandidatePairs& cand = level_candidates_[c];
    rows_[c].clear();
    participants_[c].clear();
    std::fill(seen_.begin(), seen_.end(), 0);
    for (std::size_t a = 0; a < n; ++a) {
      if (cand.row_start[a] == cand.row_start[a + 1]) continue;
      rows_[c].push_back(static_cast<ParticleIndex>(a));
      neighbours_[c].visited_rows.push_back(static_cast<std::uint32_t>(a));
      for (std::uint32_t k = cand.row_start[a]; k < cand.row_start[a + 1]; ++k)
        for (const std::size_t p : {a, std::size_t{cand.partner[k]}})
          if (level_index(level_[p]) > c) seen_[p] = 1;
    }
    for (std::size_t p = 0; p < n; ++p)
      if (seen_[p]) participants_[c].push_back(static_cast<ParticleIndex>(p));
  }

  // Members, their states and wall contacts by particle level.
  member_index_.resize(n);
  for (auto& m : members_) m.clear();
  for (auto& m : wall_members_) m.clear();
  for (std::size_t p = 0; p < n; ++p) {
    const std::size_t l = level_index(level_[p]);
    members_[l].push_back(static_cast<ParticleIndex>(p));
    if (replayed(static_cast<ParticleIndex>(p))) continue;
    member_index_[p] = static_cast<std::uint32_t>(wall_members_[l].size());
    wall_members_[l].push_back(static_cast<ParticleIndex>(p));
  }
  fill_.assign(count, 0);
  for (std::size_t k = 0; k < wall_contacts.size(); ++k) ++fill_[level_index(level_[wall_contacts.particle[k]])];
  for (std::size_t l = 0; l < count; ++l) wall_contacts_[l].resize(fill_[l]);
  fill_.assign(count, 0);
  for (std::size_t k = 0; k < wall_contacts.size(); ++k) {
    const ParticleIndex p = wall_contacts.particle[k];
    DEM_ASSERT(!replayed(p));
    const std::size_t l = level_index(level_[p]);
    WallContacts& w = wall_contacts_[l];
    const std::size_t at = fill_[l]++;
    copy_wall(wall_contacts, k, w, at);
    w.particle[at] = member_index_[p];
  }
  for (std::size_t l = 0; l < count; ++l) {
    select_particles(state_, wall_members_[l], member_state_[l]);
    wall_start_[l].assign(wall_members_[l].size() + 1, 0);
    // Its wall lists (their particles change): selected from the source's, else built at the first
    // evaluation.
    if (!source_lists_) {
      wall_lists_[l].clear();
      continue;
    }
    source_members_.clear();
    for (ParticleIndex p : wall_members_[l]) source_members_.push_back(source_slots_ ? (*source_slots_)[p] : p);
    wall_lists_[l].select(*source_lists_, source_members_);
  }
}

WallContacts MultilevelGroup::wall_contacts() const {
  WallContacts out;
  wall_contacts(out);
  return out;
}

void MultilevelGroup::wall_contacts(WallContacts& out) const {
  std::vector<KeyedSlot> order;
  std::vector<std::size_t> bounds{0};
  for (std::size_t l = 0; l < wall_contacts_.size(); ++l) {
    for (std::uint32_t k = 0; k < wall_contacts_[l].size(); ++k)
      order.push_back({wall_contacts_[l].key[k], static_cast<std::uint32_t>(l), k, 0});
    bounds.push_back(order.size());
  }
  sort_level_runs(order, bounds);
  out.resize(order.size());
  for (std::size_t q = 0; q < order.size(); ++q) {
    const KeyedSlot& from = order[q];
    copy_wall(wall_contacts_[from.level], from.slot, out, q);
    out.particle[q] = wall_members_[from.level][wall_contacts_[from.level].particle[from.slot]];
  }
}

void MultilevelGroup::evaluate_level(std::size_t c, Real h) {
  const DashpotVelocity dashpot{false, physics_.gravity, physics_.dimension};
  NeighbourContacts& nb = neighbours_[c];
  if (nb.size() > 0 || !nb.left_start.empty()) {
    physics_.kernels.neighbour_forces(view_, *physics_.materials, nb, h, dashpot);
    ended_dissipation_ +=
        finish_ended_contacts(view_, nb, rebuilt_from_[c], physics_.book_events ? &events_ : nullptr,
                              recording_ ? &ended_log_ : nullptr);
  }
  const std::vector<ParticleIndex>& members = wall_members_[c];
  if (members.empty() || walls_->count() == 0) return;
  State& sub = member_state_[c];
  for (std::size_t q = 0; q < members.size(); ++q) {
    const ParticleIndex p = members[q];
    sub.position[q] = view_.position[p];
    sub.velocity[q] = view_.velocity[p];
    sub.angular_velocity[q] = view_.angular_velocity[p];
  }
  const WallLists* lists = nullptr;
  if (physics_.wall_margin > 0) {
    WallLists& level_lists = wall_lists_[c];
    if (!level_lists.valid(sub, *walls_)) level_lists.build(sub, *walls_, physics_.wall_margin);
    lists = &level_lists;
    // No member near a wall and no wall contact to end: nothing to update, push or book.
    if (lists->listed_particles().empty() && wall_contacts_[c].size() == 0) return;
  }
  ended_dissipation_ += update_wall_contacts(sub, *walls_, *physics_.materials, wall_contacts_[c], workspace_,
                                             wall_start_[c], lists, recording_ ? &ended_log_ : nullptr);
  if (physics_.book_events) events_.record_ended(workspace_.walls, wall_contacts_[c]);
  physics_.kernels.wall_forces(sub, *physics_.materials, *walls_, wall_contacts_[c], workspace_.wall_touch, h, dashpot);
  // Work of moving walls, with the forces at the end of the step (a rectangle rule, as the fixed step's),
  // and each particle's share of it.
  if (physics_.walls_move) {
    const WallContacts& w = wall_contacts_[c];
    Real power = 0;
    for (std::size_t k = 0; k < w.size(); ++k) {
      Real contact_power = 0;
      add_wall_contact_power(*walls_, w, k, contact_power);
      power += contact_power;
      if (recording_) particle_wall_work_[members[w.particle[k]]] += h * contact_power;
    }
    wall_work_ += h * power;
  }
}

inline void MultilevelGroup::add_load(ParticleIndex p, const Vec3& force, const Vec3& torque, Real weight) {
  if (state_.inv_mass[p] == 0) return;
  if (!loaded_[p]) {
    loaded_[p] = 1;
    loaded_list_.push_back(p);
  }
  Vec3 f = force, t = torque;
  if (physics_.dimension == 2) flatten_to_plane(f), spin_about_normal(t);
  TickLoad& l = load_[p];
  l.force += f;
  l.weighted_force += weight * f;
  if (rotation_) {
    l.torque += t;
    l.weighted_torque += weight * t;
  }
}

void MultilevelGroup::clear_loads() {
  for (ParticleIndex p : loaded_list_) {
    load_[p] = TickLoad{};
    loaded_[p] = 0;
  }
  loaded_list_.clear();
}

void MultilevelGroup::add_level_loads(std::size_t c, bool use_stored_normal, Real impulse_weight, Real remaining) {
  const Real weight = 0.5 * step_of_index(c);
  const NeighbourContacts& nb = neighbours_[c];
  const PairContacts& list = nb.list;
  std::vector<std::uint32_t>& impulse_of = impulse_of_[c];
  for (ParticleIndex i : rows_[c]) {
    for (std::uint32_t k = list.row_start[i]; k < list.row_start[i + 1]; ++k) {
      if (nb.touching[k] != touching_yes) continue;
      const ParticleIndex j = list.j[k];
      const Vec3& f = list.force[k];
      Vec3 torque_i = Vec3::Zero(), torque_j = Vec3::Zero();
      if (rotation_) {
        // -a n x F on each side (n from j to i, the force on i), plus or minus the rolling torque.
        const Vec3 moment = use_stored_normal ? nb.moment[k] : Vec3(pair_normal(state_, i, j).n.cross(f));
        torque_i = -(state_.radius[i] - 0.5 * list.overlap[k]) * moment;
        torque_j = -(state_.radius[j] - 0.5 * list.overlap[k]) * moment;
        if (parts_.rolling) torque_i += list.rolling_torque[k], torque_j -= list.rolling_torque[k];
      }
      add_load(i, f, torque_i, weight);
      add_load(j, -f, torque_j, weight);
      if (impulse_of[k] == no_impulse) {
        impulse_of[k] = static_cast<std::uint32_t>(impulses_.size());
        impulses_.push_back({i, j});
      }
      ContactImpulse& sum = impulses_[impulse_of[k]];
      sum.impulse += impulse_weight * f;
      sum.moment += (impulse_weight * remaining) * f;
      sum.angular_i += impulse_weight * torque_i;
      sum.angular_j += impulse_weight * torque_j;
    }
  }
  const WallContacts& w = wall_contacts_[c];
  for (std::size_t k = 0; k < w.size(); ++k)
    add_load(wall_members_[c][w.particle[k]], w.force[k], rotation_ ? w.torque[k] : Vec3(Vec3::Zero()), weight);
}

void MultilevelGroup::begin_step(ParticleIndex p, std::int64_t t) {
  Step& s = step_[p];
  const TickLoad& l = load_[p];
  s.start = t;
  s.ticks = ticks_of_index(level_index(level_[p]));
  const Real h = step_of_index(level_index(level_[p]));
  if (replayed(p)) {
    const StepRecord& r = replayed_step(p, t, s.ticks);
    state_.position[p] = r.x0, state_.velocity[p] = r.v0, state_.angular_velocity[p] = r.w0;
    s.x0 = r.x0, s.v0 = r.v0, s.w0 = r.w0, s.a0 = r.a0, s.alpha0 = r.alpha0;
  } else {
    s.x0 = state_.position[p];
    s.v0 = state_.velocity[p];
    s.w0 = state_.angular_velocity[p];
    const Real inv_m = state_.inv_mass[p];
    s.a0 = inv_m == 0 ? Vec3(Vec3::Zero()) : Vec3(inv_m * l.force + physics_.gravity);
    s.alpha0 = state_.inv_inertia[p] * l.torque;
    if (physics_.dimension == 2) flatten_to_plane(s.a0);
    if (steps_recorded_) {
      StepRecord& r = record(p, t, s.ticks);
      r.x0 = s.x0, r.v0 = s.v0, r.w0 = s.w0, r.a0 = s.a0, r.alpha0 = s.alpha0;
    }
  }
  s.impulse = l.weighted_force;
  s.moment = h * l.weighted_force;
  s.angular_impulse = l.weighted_torque;
  s.angular_moment = h * l.weighted_torque;
  state_.force[p] = l.force;
  state_.torque[p] = l.torque;
}

void MultilevelGroup::finish_positions(std::size_t due) {
  for (std::size_t index = 0; index <= due && index < members_.size(); ++index) {
    const Real h = step_of_index(index);
    for (ParticleIndex p : members_[index]) {
      const Step& s = step_[p];
      if (replayed(p)) {
        const bool last = s.start + s.ticks == advance_ticks_;
        const Vec3 x = last ? replayed_[p].end_position : replayed_step(p, s.start + s.ticks, s.ticks).x0;
        state_.position[p] = view_.position[p] = x;
        continue;
      }
      const Real inv_m = state_.inv_mass[p];
      Vec3 x = s.x0 + h * s.v0;
      if (inv_m != 0) x += (0.5 * h * h) * physics_.gravity + inv_m * s.moment;
      if (physics_.dimension == 2) flatten_to_plane(x);
      state_.position[p] = x;
      const Real miss = (x - (s.x0 + h * s.v0 + (0.5 * h * h) * s.a0)).norm();
      miss_[p] = std::max(miss_[p], miss);
      view_.position[p] = x;
      // Partners saw it on its prediction, a parabola that strays up to |a0| H^2 / 8 from its chord,
      // which ends `miss` from where it arrived.
      excursion_[p] = std::max(excursion_[p], (x - origin_[p]).norm() + 0.125 * s.a0.norm() * h * h + miss);
    }
  }
}

void MultilevelGroup::set_view_positions(std::int64_t t, std::size_t due) {
  // The particles due at t are in view_ already (finish_positions); their coarser partners, predicted.
  const Real tick = tick_length();
  for (std::size_t c = 0; c <= due && c < participants_.size(); ++c)
    for (ParticleIndex p : participants_[c]) {
      if (level_index(level_[p]) <= due) continue;
      const Step& s = step_[p];
      const Real tau = static_cast<Real>(t - s.start) * tick;
      view_.position[p] = s.x0 + tau * s.v0 + (0.5 * tau * tau) * s.a0;
      excursion_[p] = std::max(excursion_[p], (view_.position[p] - origin_[p]).norm());
    }
}

void MultilevelGroup::set_view_motion(std::int64_t t, std::size_t c) {
  const Real tick = tick_length();
  const Real h_c = step_of_index(c);
  const auto plane = [&](ParticleIndex p) {
    if (physics_.dimension == 2) flatten_to_plane(view_.velocity[p]), spin_about_normal(view_.angular_velocity[p]);
  };
  // The finer sides: their mean velocity over the step just ended, (x - x0) / H.
  for (ParticleIndex p : members_[c]) {
    const Step& s = step_[p];
    if (replayed(p)) {
      const StepRecord& r = replayed_step(p, s.start, s.ticks);
      view_.velocity[p] = r.mean_velocity;
      view_.angular_velocity[p] = r.mean_spin;
      continue;
    }
    const Real inv_m = state_.inv_mass[p];
    Vec3 v = s.v0;
    if (inv_m != 0) v += (0.5 * h_c) * physics_.gravity + (inv_m / h_c) * s.moment;
    view_.velocity[p] = v;
    view_.angular_velocity[p] = s.w0 + (state_.inv_inertia[p] / h_c) * s.angular_moment;
    plane(p);
    if (steps_recorded_) {
      StepRecord& r = record(p, s.start, s.ticks);
      r.mean_velocity = view_.velocity[p];
      r.mean_spin = view_.angular_velocity[p];
    }
  }
  // The coarser sides: their prediction's mean over the substep [t - h_c, t].
  for (ParticleIndex p : participants_[c]) {
    const Step& s = step_[p];
    const Real mid = static_cast<Real>(t - s.start) * tick - 0.5 * h_c;
    view_.velocity[p] = s.v0 + mid * s.a0;
    view_.angular_velocity[p] = s.w0 + mid * s.alpha0;
    plane(p);
  }
}

void MultilevelGroup::end_steps(std::int64_t t, std::size_t due, bool last) {
  const Real tick = tick_length();
  // Mid-step: the force at t bounds two substeps of its contact, each weighing h/2.
  for (ParticleIndex p : loaded_list_) {
    if (level_index(level_[p]) <= due) continue;
    Step& s = step_[p];
    const TickLoad& l = load_[p];
    const Real remaining = static_cast<Real>(s.start + s.ticks - t) * tick;
    s.impulse += 2 * l.weighted_force;
    s.moment += (2 * remaining) * l.weighted_force;
    s.angular_impulse += 2 * l.weighted_torque;
    s.angular_moment += (2 * remaining) * l.weighted_torque;
  }
  for (std::size_t index = 0; index <= due && index < members_.size(); ++index) {
    const Real h = step_of_index(index);
    for (ParticleIndex p : members_[index]) {
      Step& s = step_[p];
      const TickLoad& l = load_[p];
      const Real inv_m = state_.inv_mass[p];
      if (replayed(p)) {
        const ReplayedPath& path = replayed_[p];
        const StepRecord* next = last ? nullptr : &replayed_step(p, s.start + s.ticks, s.ticks);
        state_.velocity[p] = next ? next->v0 : path.end_velocity;
        state_.angular_velocity[p] = next ? next->w0 : path.end_spin;
        if (last) {
          state_.force[p] = l.force;
          state_.torque[p] = l.torque;
        } else {
          begin_step(p, t);
        }
        continue;
      }
      if (inv_m != 0) {
        Vec3 v = s.v0 + h * physics_.gravity + inv_m * (s.impulse + l.weighted_force);
        Vec3 w = s.w0 + state_.inv_inertia[p] * (s.angular_impulse + l.weighted_torque);
        if (physics_.dimension == 2) flatten_to_plane(v), spin_about_normal(w);
        state_.velocity[p] = v;
        if (rotation_) state_.angular_velocity[p] = w;
      }
      ++particle_steps_;
      if (last) {
        state_.force[p] = l.force;
        state_.torque[p] = l.torque;
      } else {
        begin_step(p, t);
      }
    }
  }
  clear_loads();
}

void MultilevelGroup::advance(std::int64_t ticks) {
  const std::size_t n = state_.size();
  std::size_t finest = neighbours_.size() - 1;
  for (std::size_t p = 0; p < n; ++p) {
    const std::size_t index = level_index(level_[p]);
    finest = std::min(finest, index);
    if (ticks <= 0 || ticks % ticks_of_index(index) != 0)
      throw std::invalid_argument("MultilevelGroup::advance: every particle's step must divide the ticks");
  }
  if (n == 0) return;
  advance_ticks_ = ticks;
  const Real tick = tick_length();
  const Real duration = static_cast<Real>(ticks) * tick;
  // Steps are recorded while they average a few per particle: an advance of many fine steps under a
  // long coarse one would hold them all, and a retry of it redoes the whole group instead.
  steps_recorded_ = false;
  if (recording_) {
    record_start_.assign(n + 1, 0);
    std::uint64_t total = 0;  // the starts are read only when it stays within the limit
    for (std::size_t p = 0; p < n; ++p) {
      total += static_cast<std::uint64_t>(ticks / ticks_of_index(level_index(level_[p])));
      record_start_[p + 1] = static_cast<std::uint32_t>(total);
    }
    if (total <= max_records_per_particle * n) {
      records_.resize(total);
      steps_recorded_ = true;
    }
  }
  impulses_.clear();
  impulse_of_.resize(neighbours_.size());
  for (std::size_t c = 0; c < neighbours_.size(); ++c) impulse_of_[c].assign(neighbours_[c].size(), no_impulse);
  // Every particle starts a step now, from the forces its contacts hold (the last evaluation, here).
  // Loads are zero outside an advance (end_steps clears them; so does this, after an advance cut
  // short by an exception), so only new slots need setting.
  clear_loads();
  load_.resize(n);
  loaded_.resize(n);
  for (std::size_t c = 0; c < neighbours_.size(); ++c) add_level_loads(c, false, 0.5 * step_of_index(c), duration);
  step_.resize(n);
  for (std::size_t p = 0; p < n; ++p) begin_step(static_cast<ParticleIndex>(p), 0);
  clear_loads();
  const std::int64_t stride = ticks_of_index(finest);
  for (std::int64_t t = stride; t <= ticks; t += stride) {
    // Due: the particles whose step ends at t, the levels up to the largest that t is aligned to.
    std::size_t due = finest;
    while (due + 1 < neighbours_.size() && t % ticks_of_index(due + 1) == 0) ++due;
    finish_positions(due);
    set_view_positions(t, due);
    walls_->set_time(time0_ + static_cast<Real>(tick_origin_ + t) * tick);
    for (std::size_t c = finest; c <= due; ++c) {
      set_view_motion(t, c);
      evaluate_level(c, step_of_index(c));
      // A force inside the advance bounds two substeps of its contact, the last one only one.
      const Real h_c = step_of_index(c);
      add_level_loads(c, true, t == ticks ? 0.5 * h_c : h_c, static_cast<Real>(ticks - t) * tick);
    }
    end_steps(t, due, t == ticks);
  }
  tick_origin_ += ticks;
  time_ = time0_ + static_cast<Real>(tick_origin_) * tick;
}

std::vector<std::pair<ParticleIndex, ParticleIndex>> MultilevelGroup::touching_pairs() const {
  std::vector<std::pair<ParticleIndex, ParticleIndex>> out;
  for (std::size_t c = 0; c < neighbours_.size(); ++c) {
    const NeighbourContacts& nb = neighbours_[c];
    for (ParticleIndex a : rows_[c])
      for (std::uint32_t k = nb.list.row_start[a]; k < nb.list.row_start[a + 1]; ++k)
        if (nb.touching[k] == touching_yes) out.emplace_back(a, nb.list.j[k]);
  }
  return out;
}

PairContacts MultilevelGroup::pair_contacts() const {
  PairContacts out;
  pair_contacts(out);
  return out;
}

void MultilevelGroup::pair_contacts(PairContacts& out) const {
  const std::size_t n = state_.size();
  std::vector<KeyedSlot> order;
  std::vector<std::size_t> bounds{0};
  for (std::size_t c = 0; c < neighbours_.size(); ++c) {
    const NeighbourContacts& nb = neighbours_[c];
    for (ParticleIndex a : rows_[c])
      for (std::uint32_t k = nb.list.row_start[a]; k < nb.list.row_start[a + 1]; ++k)
        if (nb.touching[k] == touching_yes)
          order.push_back({pair_key(state_.id[a], state_.id[nb.list.j[k]]), static_cast<std::uint32_t>(c), k, a});
    bounds.push_back(order.size());
  }
  sort_level_runs(order, bounds);
  out.parts = parts_;
  out.resize(order.size());
  for (std::size_t q = 0; q < order.size(); ++q) {
    const KeyedSlot& from = order[q];
    copy_pair(neighbours_[from.level].list, from.slot, out, q);
    out.key[q] = from.key;
    out.i[q] = from.row;
  }
  out.index_rows(n);
}

std::size_t MultilevelGroup::memory_bytes() const {
  std::size_t total = heap_bytes(state_) + heap_bytes(view_) + heap_bytes(candidates_) + heap_bytes(level_) +
                      heap_bytes(workspace_) + heap_bytes(step_) + heap_bytes(load_) + heap_bytes(loaded_) +
                      heap_bytes(loaded_list_) + heap_bytes(excursion_) + heap_bytes(miss_) + heap_bytes(origin_) +
                      heap_bytes(fill_) + heap_bytes(member_index_) + heap_bytes(seen_) +
                      heap_bytes(level_step_) + heap_bytes(replayed_) + heap_bytes(records_) +
                      heap_bytes(record_start_) + heap_bytes(impulses_) + heap_bytes(ended_log_) +
                      heap_bytes(particle_wall_work_) + heap_bytes(source_members_);
  const auto each = [&](const auto& per_level) {
    total += heap_bytes(per_level);
    for (const auto& item : per_level) total += heap_bytes(item);
  };
  each(level_candidates_), each(neighbours_), each(rebuilt_from_), each(compact_), each(members_), each(wall_members_),
      each(impulse_of_),
      each(member_state_), each(wall_contacts_), each(wall_start_), each(rows_), each(participants_);
  total += heap_bytes(wall_lists_);
  for (const WallLists& lists : wall_lists_) total += lists.memory_bytes();
  return total;
}

}  // namespace dem

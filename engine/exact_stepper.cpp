#include "engine/exact_stepper.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "engine/contact_law.h"
#include "engine/parallel.h"

namespace dem {
namespace {

Vec3 gravity_of(const State& s, ParticleIndex p, const Vec3& g) { return s.inv_mass[p] > 0 ? g : Vec3(Vec3::Zero()); }

/// Free flight of one particle over t (t < 0 runs it backwards); immovable particles feel no gravity.
void free_flight(State& s, ParticleIndex p, const Vec3& g, Real t) {
  const Vec3 gp = gravity_of(s, p, g);
  s.position[p] += s.velocity[p] * t + 0.5 * t * t * gp;
  s.velocity[p] += t * gp;
}

/// Energy of the normal coordinate: relative kinetic + spring (while pushing) - work of the forcing.
Real normal_energy(const ExactInteraction& k, Separation sep, Real a, const NormalState& n) {
  const Real spring = pushes(k.oscillator, sep, n) ? 0.5 * k.stiffness * n.delta * n.delta : 0.0;
  return 0.5 * k.effective_mass * n.rate * n.rate + spring - k.effective_mass * a * n.delta;
}

/// P_k(tau) for a particle pair: the centre of mass in free flight, the distance by the exact normal
/// flow, the direction turned by the tangential drift.
void pair_flow(State& s, ExactInteraction& k, const ExactSettings& set, Real tau) {
  const ParticleIndex i = k.i, j = k.j;
  const Real inv_i = s.inv_mass[i], inv_j = s.inv_mass[j];
  const Vec3 gi = gravity_of(s, i, set.gravity), gj = gravity_of(s, j, set.gravity);
  const Vec3 r = s.position[i] - s.position[j];
  const Real d = r.norm();
  const Vec3 n = d > 0 ? Vec3(r / d) : Vec3(Vec3::UnitX());
  const Vec3 u = s.velocity[i] - s.velocity[j];
  const Vec3 dg = gi - gj;
  const Real a = -dg.dot(n);
  const Real reach = s.radius[i] + s.radius[j];
  const NormalState before{reach - d, -u.dot(n)};
  int events = 0;
  const NormalState after = advance_normal(k.oscillator, set.separation, a, before, tau, &events, k.half_step);
  Vec3 r_new, u_new;
  if (events == 0 && !pushes(k.oscillator, set.separation, before)) {
    // No force during the flow: plain free flight, exact.
    r_new = r + tau * u + (0.5 * tau * tau) * dg;
    u_new = u + tau * dg;
  } else {
    // The distance follows the exact normal flow; the tangential motion turns the normal and keeps
    // its speed. So the flow conserves the pair's energy exactly when undamped (a normal frozen
    // over the flow would let the tangential drift stretch the pair and leak k delta |u_t tau|^2 / 2d
    // per flow); the turn itself is first order in |u_t| tau / d (PHYSICS.md 3.3, "not exact").
    k.dissipated += normal_energy(k, set.separation, a, before) - normal_energy(k, set.separation, a, after);
    const Vec3 u_t = u + before.rate * n;
    const Vec3 dg_t = dg - dg.dot(n) * n;
    const Vec3 turned = d * n + tau * u_t + (0.5 * tau * tau) * dg_t;
    const Real turned_norm = turned.norm();
    const Vec3 n_new = turned_norm > 0 ? Vec3(turned / turned_norm) : n;
    r_new = (reach - after.delta) * n_new;
    u_new = -after.rate * n_new + law_detail::project_keep_length(u_t + tau * dg_t, n_new);
  }
  // Centre of mass, weighted by the masses (an immovable partner carries it).
  const Real w_i = inv_i / (inv_i + inv_j), w_j = inv_j / (inv_i + inv_j);
  const Vec3 x_cm = w_j * s.position[i] + w_i * s.position[j];
  const Vec3 v_cm = w_j * s.velocity[i] + w_i * s.velocity[j];
  const Vec3 g_cm = w_j * gi + w_i * gj;
  const Vec3 x_cm_new = x_cm + tau * v_cm + (0.5 * tau * tau) * g_cm;
  const Vec3 v_cm_new = v_cm + tau * g_cm;
  s.position[i] = x_cm_new + w_i * r_new;
  s.position[j] = x_cm_new - w_j * r_new;
  s.velocity[i] = v_cm_new + w_i * u_new;
  s.velocity[j] = v_cm_new - w_j * u_new;
}

/// P_k(tau) for a particle against a wall (infinite mass, its velocity at the contact frozen).
void wall_flow(State& s, const Walls& walls, ExactInteraction& k, const ExactSettings& set, Real tau) {
  const ParticleIndex p = k.i;
  const Vec3 g = gravity_of(s, p, set.gravity);
  const Real r = s.radius[p];
  // Geometry with a padded radius: beyond the pad the particle cannot reach the wall within tau.
  const Real pad = r + s.velocity[p].norm() * tau + 0.5 * g.norm() * tau * tau;
  WallTouch t;
  if (!walls.touch(k.wall, k.feature, s.position[p], r + pad, t)) {
    free_flight(s, p, set.gravity, tau);
    return;
  }
  const Vec3 n = t.normal;
  const Real overlap = t.overlap - pad;
  const Vec3 v_wall = walls.velocity_at(k.wall, s.position[p] - (r - 0.5 * overlap) * n);
  const Vec3 u = s.velocity[p] - v_wall;
  const NormalState start{overlap, -u.dot(n)};
  const Real a = -g.dot(n);
  const NormalState after = advance_normal(k.oscillator, set.separation, a, start, tau, nullptr, k.half_step);
  k.dissipated += normal_energy(k, set.separation, a, start) - normal_energy(k, set.separation, a, after);
  const Vec3 u_t = u + start.rate * n;
  const Vec3 g_t = g - g.dot(n) * n;
  s.position[p] += tau * v_wall + (start.delta - after.delta) * n + tau * u_t + (0.5 * tau * tau) * g_t;
  s.velocity[p] = v_wall - after.rate * n + u_t + tau * g_t;
}

void flow(State& s, const Walls& walls, ExactInteraction& k, const ExactSettings& set, Real tau) {
  if (k.wall == ExactInteraction::no_wall) pair_flow(s, k, set, tau);
  else wall_flow(s, walls, k, set, tau);
}

/// Free drift of the particles of interaction k over t.
void drift(State& s, const ExactInteraction& k, const Vec3& g, Real t) {
  free_flight(s, k.i, g, t);
  if (k.wall == ExactInteraction::no_wall) free_flight(s, k.j, g, t);
}

NormalOscillator oscillator_of(const LawConstants& c, Real m_star) {
  return {std::sqrt(c.k_n / m_star), c.c_n / (2 * m_star)};
}

/// The interactions of this step: candidate pairs and wall features that can touch within h.
/// Key of an interaction for the sorted `forced` list: particle, then partner slot or wall feature.
std::uint64_t interaction_key(ParticleIndex a, std::uint64_t partner) { return (std::uint64_t{a} << 32) | partner; }
std::uint64_t wall_partner(std::size_t w, std::uint32_t f) { return 0x80000000u | (w << 8) | f; }

bool forced_contains(const std::vector<std::uint64_t>& forced, std::uint64_t key) {
  return std::binary_search(forced.begin(), forced.end(), key);
}

void collect_interactions(const State& s, const Walls& walls, const MaterialTable& materials,
                          const broadphase::CandidatePairs& candidates, const ExactSettings& set, Real h,
                          ExactWorkspace& work) {
  const std::size_t n = s.size();
  auto pair_interacts = [&](ParticleIndex a, ParticleIndex b) {
    if (s.inv_mass[a] == 0 && s.inv_mass[b] == 0) return false;
    if (forced_contains(work.forced, interaction_key(a, b))) return true;
    const Real gap = (s.position[a] - s.position[b]).norm() - s.radius[a] - s.radius[b];
    const Vec3 dg = gravity_of(s, a, set.gravity) - gravity_of(s, b, set.gravity);
    return gap <= anticipation_factor * ((s.velocity[a] - s.velocity[b]).norm() * h + 0.5 * dg.norm() * h * h);
  };
  auto wall_interacts = [&](ParticleIndex p, std::size_t w, std::uint32_t f) {
    if (s.inv_mass[p] == 0) return false;
    if (forced_contains(work.forced, interaction_key(p, wall_partner(w, f)))) return true;
    const Real reach = anticipation_factor * ((s.velocity[p] - walls.velocity_at(w, s.position[p])).norm() * h +
                                              0.5 * set.gravity.norm() * h * h);
    WallTouch t;
    return walls.touch(w, f, s.position[p], s.radius[p] + reach, t);
  };
  work.count.assign(n, 0);
  parallel_for(n, [&](std::size_t a) {
    std::uint32_t c = 0;
    for (std::uint32_t k = candidates.row_start[a]; k < candidates.row_start[a + 1]; ++k)
      c += pair_interacts(static_cast<ParticleIndex>(a), candidates.partner[k]) ? 1 : 0;
    for (std::size_t w = 0; w < walls.count(); ++w)
      for (std::uint32_t f = 0; f < walls.feature_count(w); ++f)
        c += wall_interacts(static_cast<ParticleIndex>(a), w, f) ? 1 : 0;
    work.count[a] = c;
  });
  exclusive_scan(work.count, work.offset);
  work.interactions.resize(work.offset[n]);
  parallel_for(n, [&](std::size_t a0) {
    const auto a = static_cast<ParticleIndex>(a0);
    std::uint32_t slot = work.offset[a];
    for (std::uint32_t k = candidates.row_start[a]; k < candidates.row_start[a + 1]; ++k) {
      const ParticleIndex b = candidates.partner[k];
      if (!pair_interacts(a, b)) continue;
      const EffectiveMasses m =
          effective_masses(s.inv_mass[a], s.inv_inertia[a], s.radius[a], s.inv_mass[b], s.inv_inertia[b], s.radius[b]);
      const LawConstants c = materials.constants(materials.pair_class(s.material[a], s.material[b]), m);
      work.interactions[slot++] = {a, b, ExactInteraction::no_wall, 0, oscillator_of(c, m.m_star), c.k_n, m.m_star, 0, nullptr};
    }
    for (std::size_t w = 0; w < walls.count(); ++w)
      for (std::uint32_t f = 0; f < walls.feature_count(w); ++f) {
        if (!wall_interacts(a, w, f)) continue;
        const EffectiveMasses m = effective_masses(s.inv_mass[a], s.inv_inertia[a], s.radius[a], 0, 0,
                                                   std::numeric_limits<Real>::infinity());
        const LawConstants c = materials.constants(materials.pair_class(s.material[a], walls.material(w)), m);
        work.interactions[slot++] = {a, a, static_cast<std::uint32_t>(w), f, oscillator_of(c, m.m_star), c.k_n,
                                     m.m_star, 0, nullptr};
      }
  });
}

}  // namespace

Real max_free_displacement(const State& s, const Vec3& gravity, Real h) {
  Real largest = 0;  // a maximum is exact in any order
  for (std::size_t p = 0; p < s.size(); ++p)
    largest = std::max(largest, s.velocity[p].norm() * h + (s.inv_mass[p] > 0 ? 0.5 * gravity.norm() * h * h : 0.0));
  return largest;
}

namespace {

std::uint64_t key_of(const ExactInteraction& k) {
  return interaction_key(k.i, k.wall == ExactInteraction::no_wall ? std::uint64_t{k.j} : wall_partner(k.wall, k.feature));
}

/// Contacts touching at the end of a step that were not among its interactions (so no force acted
/// on them), appended to `missed` as sorted interaction keys. The interactions of row a lie in
/// [offset[a], offset[a+1]) in ascending key order (pairs by partner, then walls), so each row is
/// checked on its own, in parallel; the rare list of misses is then built serially.
void find_missed(const State& s, const Walls& walls, const broadphase::CandidatePairs& candidates,
                 const ExactWorkspace& work, std::vector<std::uint64_t>& missed) {
  auto missed_in_row = [&](std::size_t a, std::vector<std::uint64_t>* out) {
    const auto first = work.interactions.begin() + work.offset[a], last = work.interactions.begin() + work.offset[a + 1];
    bool any = false;
    auto check = [&](std::uint64_t key) {
      const auto it = std::lower_bound(first, last, key, [](const ExactInteraction& k, std::uint64_t x) { return key_of(k) < x; });
      if (it != last && key_of(*it) == key) return;
      any = true;
      if (out) out->push_back(key);
    };
    for (std::uint32_t k = candidates.row_start[a]; k < candidates.row_start[a + 1]; ++k) {
      const ParticleIndex b = candidates.partner[k];
      const Real reach = s.radius[a] + s.radius[b];
      if ((s.inv_mass[a] > 0 || s.inv_mass[b] > 0) && (s.position[a] - s.position[b]).squaredNorm() < reach * reach)
        check(interaction_key(static_cast<ParticleIndex>(a), b));
    }
    WallTouch t;
    for (std::size_t w = 0; w < walls.count(); ++w)
      for (std::uint32_t f = 0; f < walls.feature_count(w); ++f)
        if (s.inv_mass[a] > 0 && walls.touch(w, f, s.position[a], s.radius[a], t))
          check(interaction_key(static_cast<ParticleIndex>(a), wall_partner(w, f)));
    return any;
  };
  if (!parallel_any(s.size(), [&](std::size_t a) { return missed_in_row(a, nullptr); })) return;
  for (std::size_t a = 0; a < s.size(); ++a) missed_in_row(a, &missed);
}

Real compose(State& s, Walls& walls, const ExactSettings& set, Real t, Real h, ExactWorkspace& work);

std::uint64_t bits_of(Real x) {
  std::uint64_t b;
  std::memcpy(&b, &x, sizeof b);
  return b;
}

/// Points every interaction at the table's coefficients for its oscillator over tau (serial: the
/// table inserts; the flows then only read).
void attach_coefficients(ExactWorkspace& work, Real tau) {
  if (work.table_step != tau || work.class_of.size() > ExactWorkspace::table_capacity) {
    work.class_of.clear();
    work.table.clear();
    work.table_step = tau;
  }
  for (ExactInteraction& k : work.interactions) {
    const auto key = std::make_pair(bits_of(k.oscillator.omega0), bits_of(k.oscillator.beta));
    const auto [it, inserted] = work.class_of.try_emplace(key, static_cast<std::uint32_t>(work.class_of.size()));
    (void)inserted;
    k.half_step = &work.table.get(it->second, 0, k.oscillator.omega0, k.oscillator.beta, tau);
  }
}

}  // namespace

Real exact_step(State& s, Walls& walls, const MaterialTable& materials,
                const broadphase::CandidatePairs& candidates, const ExactSettings& set, Real t, Real h,
                ExactWorkspace& work) {
  // A contact that the anticipation missed (another contact changed a velocity within the step)
  // would start the next step overlapped, with energy from nothing: redo the step from the saved
  // state with the missed contacts included, until none is missed.
  work.saved_position = s.position;
  work.saved_velocity = s.velocity;
  work.forced.clear();
  for (int attempt = 0;; ++attempt) {
    walls.set_time(t);
    collect_interactions(s, walls, materials, candidates, set, h, work);
    if (set.use_table) attach_coefficients(work, 0.5 * h);
    const Real dissipated = compose(s, walls, set, t, h, work);
    walls.set_time(t + h);
    std::vector<std::uint64_t> missed;
    if (attempt < 8) find_missed(s, walls, candidates, work, missed);
    if (missed.empty()) return dissipated;
    work.forced.insert(work.forced.end(), missed.begin(), missed.end());
    std::sort(work.forced.begin(), work.forced.end());
    s.position = work.saved_position;
    s.velocity = work.saved_velocity;
    ++work.retries;
  }
}

namespace {

Real compose(State& s, Walls& walls, const ExactSettings& set, Real t, Real h, ExactWorkspace& work) {
  // Colour the interaction graph; a wall contact is an edge to a node of its own.
  const std::size_t n = s.size(), m = work.interactions.size();
  work.edge_i.resize(m);
  work.edge_j.resize(m);
  for (std::size_t k = 0; k < m; ++k) {
    const ExactInteraction& x = work.interactions[k];
    work.edge_i[k] = x.i;
    work.edge_j[k] = x.wall == ExactInteraction::no_wall ? x.j : static_cast<ParticleIndex>(n + k);
  }
  color_contacts(n + m, work.edge_i, work.edge_j, work.coloring);
  const ContactColoring& col = work.coloring;
  const Real half = 0.5 * h;
  auto colour = [&](std::size_t c, bool adjoint) {
    parallel_for(col.start[c + 1] - col.start[c], [&](std::size_t e) {
      ExactInteraction& k = work.interactions[col.contact[col.start[c] + e]];
      if (adjoint) {
        drift(s, k, set.gravity, -half);
        flow(s, walls, k, set, half);
      } else {
        flow(s, walls, k, set, half);
        drift(s, k, set.gravity, -half);
      }
    });
  };
  // Each sweep's wall flows cover half a step from its start: walls at their pose at t, then t + h/2.
  walls.set_time(t);
  for (std::size_t c = 0; c < col.color_count(); ++c) colour(c, false);
  parallel_for(n, [&](std::size_t p) { free_flight(s, static_cast<ParticleIndex>(p), set.gravity, h); });
  walls.set_time(t + half);
  for (std::size_t c = col.color_count(); c-- > 0;) colour(c, true);
  if (set.dimension == 2)
    parallel_for(n, [&](std::size_t p) {
      s.position[p].z() = 0;
      s.velocity[p].z() = 0;
    });
  return block_sum<Real>(m, [&](std::size_t k) { return work.interactions[k].dissipated; });
}

}  // namespace
}  // namespace dem

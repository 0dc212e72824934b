#include "engine/forces.h"

#include <cmath>
#include <cstring>
#include <limits>

#include "engine/checks.h"
#include "engine/parallel.h"

namespace dem {
namespace {

// A pair contact's history as the law sees it (PairContacts::history, with the parts fixed by the
// law at compile time: the list holds exactly those, pair_forces checks); the energy books only
// when the list keeps them (collision spectra).
template <class Law>
ContactHistory load_history(const PairContacts& c, std::size_t k, bool books) {
  ContactHistory h;
  if constexpr (Law::friction) h.tangential_spring = c.tangential_spring[k];
  if constexpr (Law::rolling) h.rolling_spring = c.rolling_spring[k];
  h.mode = c.mode[k];
  if (books) {
    const EnergyBooks& b = c.books[k];
    h.normal_work = b.normal_work, h.normal_elastic = b.normal_elastic, h.impact_energy = b.impact_energy;
  }
  return h;
}

template <class Law>
void store_history(PairContacts& c, std::size_t k, bool books, const ContactHistory& h) {
  if constexpr (Law::friction) c.tangential_spring[k] = h.tangential_spring;
  if constexpr (Law::rolling) c.rolling_spring[k] = h.rolling_spring;
  c.mode[k] = h.mode;
  if (books) c.books[k] = {h.normal_work, h.normal_elastic, h.impact_energy};
}

/// A particle's velocity and spin.
struct Motion {
  Vec3 velocity;
  Vec3 angular_velocity;
};

Motion motion_of(const State& s, ParticleIndex p) { return {s.velocity[p], s.angular_velocity[p]}; }

/// The motion its dashpots see when they are predicted (DashpotVelocity): the half-step values with
/// the second half kick of the previous forces added, as kick() would apply it.
Motion predicted_motion(const State& s, ParticleIndex p, Real h, const DashpotVelocity& d) {
  Motion m = motion_of(s, p);
  const Real inv_m = s.inv_mass[p];
  if (inv_m == 0) return m;
  m.velocity += (0.5 * h) * (inv_m * s.force[p] + d.gravity);
  if (d.dimension == 2) m.velocity.z() = 0;
  m.angular_velocity += (0.5 * h * s.inv_inertia[p]) * s.torque[p];
  return m;
}

/// Relative motion at a contact: the contact-point velocity u of i against j and the rolling
/// velocity omega_r (the relative spin without its part about n).
struct SurfaceMotion {
  Vec3 u;
  Vec3 rolling = Vec3::Zero();
};

/// Contact-point velocities of a pair: omega_i x (-a_i n) - omega_j x (a_j n) (docs/physics.md 1.2).
/// The rolling velocity only for a law with rolling resistance (no other law reads it: it stays 0).
template <bool Rotation, bool Rolling>
SurfaceMotion pair_surface(const Motion& a, const Motion& b, Real arm_a, Real arm_b, const Vec3& n) {
  SurfaceMotion m{a.velocity - b.velocity};
  if constexpr (Rotation) m.u -= (arm_a * a.angular_velocity + arm_b * b.angular_velocity).cross(n);
  if constexpr (Rolling) {
    m.rolling = a.angular_velocity - b.angular_velocity;
    m.rolling -= m.rolling.dot(n) * n;
  }
  return m;
}

/// The same against a wall whose material at the contact point moves at `wall_velocity` and spins
/// at `wall_spin`.
template <bool Rotation, bool Rolling>
SurfaceMotion wall_surface(const Motion& a, const Vec3& wall_velocity, const Vec3& wall_spin, Real arm,
                           const Vec3& n) {
  SurfaceMotion m{a.velocity - wall_velocity};
  if constexpr (Rotation) m.u -= arm * a.angular_velocity.cross(n);
  if constexpr (Rolling) {
    m.rolling = a.angular_velocity - wall_spin;
    m.rolling -= m.rolling.dot(n) * n;
  }
  return m;
}

/// The rates of `kin` from the half-step motion, and the dashpots' from `damped` (the same motion
/// unless the run predicts it).
void set_rates(ContactKinematics& kin, const SurfaceMotion& half_step, const SurfaceMotion* damped) {
  const Vec3& n = kin.normal;
  kin.overlap_rate = -half_step.u.dot(n);
  kin.tangential_velocity = half_step.u + kin.overlap_rate * n;
  kin.rolling_velocity = half_step.rolling;
  if (!damped) {
    kin.dashpot_overlap_rate = kin.overlap_rate;
    kin.dashpot_tangential_velocity = kin.tangential_velocity;
    kin.dashpot_rolling_velocity = kin.rolling_velocity;
    return;
  }
  kin.dashpot_overlap_rate = -damped->u.dot(n);
  kin.dashpot_tangential_velocity = damped->u + kin.dashpot_overlap_rate * n;
  kin.dashpot_rolling_velocity = damped->rolling;
}

/// What the law constants of pair (i, j) are made from.
LawInputs pair_inputs(const State& s, const MaterialTable& materials, ParticleIndex i, ParticleIndex j) {
  return {materials.pair_class(s.material[i], s.material[j]), s.inv_mass[i], s.inv_inertia[i], s.radius[i],
          s.inv_mass[j], s.inv_inertia[j], s.radius[j]};
}

/// Equal constants, bit for bit (the memo keyed on kinds is checked against the table with it).
[[maybe_unused]] bool law_constants_equal(const LawConstants& a, const LawConstants& b) {
  return std::memcmp(&a, &b, sizeof a) == 0;
}

/// Evaluates pair contact k of `c` (between particles i and j, with law constants `constants`) and
/// writes its slots: force, rolling torque, history, overlap and books; and n x force into `moment`
/// when given (n the unit normal from j to i), here where both are still in registers. Flattened:
/// the surface-motion, rate and law helpers are inlined into it, so their structs stay in registers
/// instead of passing through memory.
template <class Law>
[[gnu::flatten]] void evaluate_pair(const State& s, const LawConstants& constants, PairContacts& c, std::size_t k,
                                    ParticleIndex i, ParticleIndex j, Real h,
                                    const DashpotVelocity& d, bool books, Vec3* moment = nullptr) {
  const auto [n, dist] = pair_normal(s, i, j);
  const Real overlap = s.radius[i] + s.radius[j] - dist;
  const Real arm_i = s.radius[i] - 0.5 * overlap, arm_j = s.radius[j] - 0.5 * overlap;  // as gather_forces
  constexpr bool rotation = Law::uses_rotation;
  const SurfaceMotion half_step =
      pair_surface<rotation, Law::rolling>(motion_of(s, i), motion_of(s, j), arm_i, arm_j, n);
  ContactKinematics kin;
  kin.normal = n;
  kin.overlap = overlap;
  kin.previous_force = c.force[k];
  if (d.predicted) {
    const SurfaceMotion damped = pair_surface<rotation, Law::rolling>(
        predicted_motion(s, i, h, d), predicted_motion(s, j, h, d), arm_i, arm_j, n);
    set_rates(kin, half_step, &damped);
  } else {
    set_rates(kin, half_step, nullptr);
  }
  kin.onset = c.overlap[k] == 0;  // a new contact: no evaluation has stored its overlap yet
  ContactHistory history = load_history<Law>(c, k, books);
  const Real inv_m = s.inv_mass[i] + s.inv_mass[j];  // two fixed particles: no impact energy
  if (books && history.impact_energy < 0)
    history.impact_energy = inv_m > 0 ? 0.5 * kin.overlap_rate * kin.overlap_rate / inv_m : 0;
  const ContactResponse r = Law::evaluate(constants, kin, history, h);
  history.normal_work += h * r.normal_power;
  history.normal_elastic = r.normal_elastic;
  store_history<Law>(c, k, books, history);
  c.overlap[k] = overlap;
  c.work[k] += h * r.power;
  c.elastic[k] = r.elastic;
  c.force[k] = r.force;
  if constexpr (Law::rolling) c.rolling_torque[k] = r.rolling_torque;
  if (moment) *moment = n.cross(r.force);
}

template <class Law>
void pair_forces(const State& s, const MaterialTable& materials, PairContacts& c, Real h, const DashpotVelocity& d) {
  DEM_ASSERT(c.parts.friction == Law::friction && c.parts.rolling == Law::rolling);
  const bool books = c.parts.books;
  parallel_chunks(c.size(), [&](std::size_t begin, std::size_t end) {
    LawConstantsMemo<LawInputs> memo;
    for (std::size_t k = begin; k < end; ++k) {
      const ParticleIndex i = c.i[k], j = c.j[k];
      const LawInputs inputs = pair_inputs(s, materials, i, j);
      const LawConstants& constants =
          memo.get(inputs, [&] { return materials.law_constants<Law::friction, Law::rolling>(inputs); });
      evaluate_pair<Law>(s, constants, c, k, i, j, h, d, books);
    }
  });
}

/// Row by row over the persistent list: a slot whose pair overlaps is evaluated (a contact that
/// starts has start values, so this is its onset); one that touched and no longer overlaps has its
/// release step booked and is marked ended for finish_ended_contacts, which books and resets it.
/// A row is taken a stretch of slots at a time: first every slot is sorted, without a branch, into
/// those to evaluate and those that end, then each kind is handled in slot order. Which candidates
/// touch is close to random in a dense bed; deciding it slot by slot in front of the law made the
/// processor discard the law's work at most slots (a wrong guess), where the law now runs contact
/// after contact. Every slot's work reads the state and writes its own slot only, so the order
/// between kinds changes no result; the ended sum and the deepest contact still go in slot order.
template <class Law>
void neighbour_forces(const State& s, const MaterialTable& materials, NeighbourContacts& nb, Real h,
                      const DashpotVelocity& d) {
  PairContacts& c = nb.list;
  DEM_ASSERT(c.parts.friction == Law::friction && c.parts.rolling == Law::rolling);
  const bool books = c.parts.books;
  // Contacts left behind may sit in any row: then every row is visited.
  const bool sparse = !nb.visited_rows.empty() && nb.left_start.empty();
  DEM_ASSERT(nb.kind.size() == s.size());  // numbered by the last rebuild, for these particles
  const auto row_forces = [&](LawConstantsMemo<std::uint64_t>& memo, std::size_t r) {
    const std::size_t a = sparse ? nb.visited_rows[r] : r;
    Real ended = 0;
    std::uint8_t any_ended = 0;
    Real deepest = 0;
    std::uint32_t deepest_slot = no_deepest_slot;
    // Contacts the last rebuild left behind end here too, summed in key order with the slots' own.
    std::uint32_t q = nb.left_start.empty() ? 0 : nb.left_start[a];
    const std::uint32_t q_end = nb.left_start.empty() ? 0 : nb.left_start[a + 1];
    const auto end_left_before = [&](std::uint64_t key) {
      for (; q < q_end && nb.left_key[q] < key; ++q) {
        ended += nb.left_dissipated[q];
        any_ended = 1;
      }
    };
    const ParticleIndex i = static_cast<ParticleIndex>(a);
    const Real r_i = s.radius[i];
    const std::uint64_t kinds_i = std::uint64_t{nb.kind[i]} << 32;  // the memo's key: both kinds
    constexpr std::uint32_t stretch = 16;
    std::uint32_t evaluated[stretch], ending[stretch];  // slots of the stretch, ascending
    for (std::uint32_t begin = c.row_start[a]; begin < c.row_start[a + 1]; begin += stretch) {
      const std::uint32_t end = std::min(begin + stretch, c.row_start[a + 1]);
      std::uint32_t n_evaluated = 0, n_ending = 0;
      for (std::uint32_t k = begin; k < end; ++k) {  // each slot is written to both, and kept by one or none
        const bool touches = pair_touches(s, i, c.j[k]);
        evaluated[n_evaluated] = k;
        n_evaluated += touches;
        ending[n_ending] = k;
        n_ending += !touches & (nb.touching[k] == touching_yes);
      }
      for (std::uint32_t e = 0; e < n_evaluated; ++e) {
        const std::uint32_t k = evaluated[e];
        const ParticleIndex j = c.j[k];
        const auto table_constants = [&] {
          return materials.law_constants<Law::friction, Law::rolling>(pair_inputs(s, materials, i, j));
        };
        const LawConstants& constants = memo.get(kinds_i | nb.kind[j], table_constants);
        DEM_VALIDATE(law_constants_equal(constants, table_constants()));
        evaluate_pair<Law>(s, constants, c, k, i, j, h, d, books, Law::uses_rotation ? &nb.moment[k] : nullptr);
        nb.touching[k] = touching_yes;
        // The row's deepest: the first of equal ratios, a NaN before any number (deepest_contact).
        const Real ratio = overlap_ratio(c.overlap[k], r_i, s.radius[j]);
        if (deepest_slot == no_deepest_slot || (!std::isnan(deepest) && (std::isnan(ratio) || ratio > deepest))) {
          deepest = ratio;
          deepest_slot = k;
        }
      }
      for (std::uint32_t e = 0; e < n_ending; ++e) {
        const std::uint32_t k = ending[e];
        const ParticleIndex j = c.j[k];
        if (q < q_end) end_left_before(pair_key(s.id[i], s.id[j]));
        ended += release_pair_contact(s, materials, i, j, c, k);
        nb.touching[k] = touching_ended;
        any_ended = 1;
      }
    }
    end_left_before(~std::uint64_t{0});
    nb.row_ended[a] = ended;
    nb.row_has_ended[a] = any_ended;
    nb.row_deepest[a] = deepest;
    nb.row_deepest_slot[a] = deepest_slot;
  };
  parallel_chunks(sparse ? nb.visited_rows.size() : c.row_start.size() - 1, [&](std::size_t begin, std::size_t end) {
    LawConstantsMemo<std::uint64_t> memo;
    for (std::size_t r = begin; r < end; ++r) row_forces(memo, r);
  });
}

template <class Law>
void wall_forces(const State& s, const MaterialTable& materials, const Walls& walls, WallContacts& c,
                 const std::vector<WallTouch>& touches, Real h, const DashpotVelocity& d) {
  DEM_ASSERT(touches.size() == c.size());
  const auto contact_force = [&](LawConstantsMemo<LawInputs>& memo, std::size_t k) {
    const ParticleIndex p = c.particle[k];
    const std::uint32_t w = c.wall[k];
    // Contacts are rebuilt at these very positions: every one touches, with this geometry.
    const WallTouch& touch = touches[k];
    const Vec3& n = touch.normal;
    const Real arm = s.radius[p] - 0.5 * touch.overlap;
    const Vec3 point = s.position[p] - arm * n;
    const Vec3 wall_velocity = walls.velocity_at(w, point);
    constexpr bool rotation = Law::uses_rotation;
    const Vec3 wall_spin = rotation ? walls.angular_velocity(w) : Vec3::Zero();
    const SurfaceMotion half_step =
        wall_surface<rotation, Law::rolling>(motion_of(s, p), wall_velocity, wall_spin, arm, n);
    ContactKinematics kin;
    kin.normal = n;
    kin.overlap = touch.overlap;
    kin.previous_force = c.force[k];
    if (d.predicted) {
      const SurfaceMotion damped =
          wall_surface<rotation, Law::rolling>(predicted_motion(s, p, h, d), wall_velocity, wall_spin, arm, n);
      set_rates(kin, half_step, &damped);
    } else {
      set_rates(kin, half_step, nullptr);
    }
    kin.onset = c.overlap[k] == 0;  // a new contact: no evaluation has stored its overlap yet
    ContactHistory& history = c.history[k];
    if (history.impact_energy < 0) history.impact_energy = 0.5 * kin.overlap_rate * kin.overlap_rate / s.inv_mass[p];
    const LawInputs inputs{materials.pair_class(s.material[p], walls.material(w)), s.inv_mass[p], s.inv_inertia[p],
                           s.radius[p], 0, 0, std::numeric_limits<Real>::infinity()};
    const LawConstants& constants =
        memo.get(inputs, [&] { return materials.law_constants<Law::friction, Law::rolling>(inputs); });
    const ContactResponse r = Law::evaluate(constants, kin, history, h);
    history.normal_work += h * r.normal_power;
    history.normal_elastic = r.normal_elastic;
    c.overlap[k] = touch.overlap;
    c.work[k] += h * r.power;
    c.elastic[k] = r.elastic;
    c.point[k] = point;
    c.force[k] = r.force;
    if constexpr (Law::uses_rotation) {
      c.torque[k] = -arm * n.cross(r.force) + r.rolling_torque;
      c.rolling_torque[k] = r.rolling_torque;
    } else {
      c.rolling_torque[k].setZero();
    }
  };
  parallel_chunks(c.size(), [&](std::size_t begin, std::size_t end) {
    LawConstantsMemo<LawInputs> memo;
    for (std::size_t k = begin; k < end; ++k) contact_force(memo, k);
  });
}

template <class Law>
ForceKernels kernels_for() {
  return ForceKernels{&pair_forces<Law>, &neighbour_forces<Law>, &wall_forces<Law>, Law::uses_rotation};
}

template <Separation Sep, bool Friction>
ForceKernels select_rolling(RollingKind rolling) {
  switch (rolling) {
    case RollingKind::none: return kernels_for<LinearSpringDashpot<Sep, Friction, RollingKind::none>>();
    case RollingKind::standard: return kernels_for<LinearSpringDashpot<Sep, Friction, RollingKind::standard>>();
    case RollingKind::seed: return kernels_for<LinearSpringDashpot<Sep, Friction, RollingKind::seed>>();
  }
  return {};
}

template <Separation Sep>
ForceKernels select_friction(bool friction, RollingKind rolling) {
  return friction ? select_rolling<Sep, true>(rolling) : select_rolling<Sep, false>(rolling);
}

}  // namespace

ForceKernels select_force_kernels(Separation separation, bool friction, RollingKind rolling) {
  return separation == Separation::force_zero ? select_friction<Separation::force_zero>(friction, rolling)
                                              : select_friction<Separation::overlap>(friction, rolling);
}

void gather_forces(State& s, const PairContacts& pairs, const WallContacts& walls, const ContactAdjacency& adjacency,
                   bool rotation, int dimension) {
  const bool rolling = pairs.parts.rolling;
  parallel_for(s.size(), [&](std::size_t p) {
    Vec3 f = Vec3::Zero(), t = Vec3::Zero();
    for (std::uint32_t e = adjacency.pair_start[p]; e < adjacency.pair_start[p + 1]; ++e) {
      const std::uint32_t entry = adjacency.pair_entry[e];
      const std::uint32_t k = entry >> 1;
      const bool is_i = (entry & 1) == 0;
      if (is_i)
        f += pairs.force[k];
      else
        f -= pairs.force[k];
      if (rotation) {
        // -a n x force, plus or minus the rolling torque; n exactly as pair_forces computed it, from the
        // same positions (only the tangential part of the force has a moment). Without rolling it lacks
        // only the "+ 0", which changes nothing in a sum that starts at +0.
        const Vec3 n = pair_normal(s, pairs.i[k], pairs.j[k]).n;
        const Real arm = s.radius[p] - 0.5 * pairs.overlap[k];
        Vec3 torque = -arm * n.cross(pairs.force[k]);
        if (rolling) torque += is_i ? pairs.rolling_torque[k] : Vec3(-pairs.rolling_torque[k]);
        t += torque;
      }
    }
    for (std::uint32_t k = adjacency.wall_start[p]; k < adjacency.wall_start[p + 1]; ++k) {
      f += walls.force[k];
      if (rotation) t += walls.torque[k];
    }
    if (dimension == 2) {  // discs: no motion out of the xy plane, spin only about z
      f.z() = 0;
      t.x() = 0;
      t.y() = 0;
    }
    s.force[p] = f;
    s.torque[p] = t;
  });
}

namespace {

template <bool Rotation, bool Rolling, bool Disc>
void gather_neighbours(State& s, const NeighbourContacts& nb, const WallContacts& walls,
                       const std::vector<std::uint32_t>& wall_start) {
  const PairContacts& c = nb.list;
  parallel_for(s.size(), [&](std::size_t p) {
    Vec3 f = Vec3::Zero(), t = Vec3::Zero();
    const Real r = s.radius[p];
    // Partners with smaller ids first (p is j of those slots), then the row's own (p is i): ascending
    // partner order, as gather_forces sums a compact list.
    for (std::uint32_t e = nb.reverse_start[p]; e < nb.reverse_start[p + 1]; ++e) {
      const std::uint32_t k = nb.reverse_slot[e];
      f -= c.force[k];
      if constexpr (Rotation) {
        Vec3 torque = -(r - 0.5 * c.overlap[k]) * nb.moment[k];
        if constexpr (Rolling) torque += -c.rolling_torque[k];
        t += torque;
      }
    }
    for (std::uint32_t k = c.row_start[p]; k < c.row_start[p + 1]; ++k) {
      f += c.force[k];
      if constexpr (Rotation) {
        Vec3 torque = -(r - 0.5 * c.overlap[k]) * nb.moment[k];
        if constexpr (Rolling) torque += c.rolling_torque[k];
        t += torque;
      }
    }
    for (std::uint32_t k = wall_start[p]; k < wall_start[p + 1]; ++k) {
      f += walls.force[k];
      if constexpr (Rotation) t += walls.torque[k];
    }
    if constexpr (Disc) {
      f.z() = 0;
      t.x() = 0;
      t.y() = 0;
    }
    s.force[p] = f;
    s.torque[p] = t;
  });
}

template <bool Rotation, bool Rolling>
void gather_neighbours_in(State& s, const NeighbourContacts& nb, const WallContacts& walls,
                          const std::vector<std::uint32_t>& wall_start, int dimension) {
  if (dimension == 2)
    gather_neighbours<Rotation, Rolling, true>(s, nb, walls, wall_start);
  else
    gather_neighbours<Rotation, Rolling, false>(s, nb, walls, wall_start);
}

}  // namespace

void gather_neighbour_forces(State& s, const NeighbourContacts& nb, const WallContacts& walls,
                             const std::vector<std::uint32_t>& wall_start, bool rotation, int dimension) {
  const bool rolling = nb.list.parts.rolling;
  if (!rotation)
    gather_neighbours_in<false, false>(s, nb, walls, wall_start, dimension);
  else if (rolling)
    gather_neighbours_in<true, true>(s, nb, walls, wall_start, dimension);
  else
    gather_neighbours_in<true, false>(s, nb, walls, wall_start, dimension);
}

void add_wall_contact_power(const Walls& walls, const WallContacts& c, std::size_t k, Real& power) {
  power += c.force[k].dot(walls.velocity_at(c.wall[k], c.point[k]));
  power += c.rolling_torque[k].dot(walls.angular_velocity(c.wall[k]));
}

Real wall_power(const Walls& walls, const WallContacts& c) {
  Real power = 0;
  for (std::size_t k = 0; k < c.size(); ++k) add_wall_contact_power(walls, c, k, power);
  return power;
}

void accumulate_wall_loads(const Walls& walls, const WallContacts& c, std::vector<WallLoad>& loads) {
  loads.assign(walls.count(), WallLoad{});
  for (std::size_t k = 0; k < c.size(); ++k) {
    WallLoad& load = loads[c.wall[k]];
    load.force -= c.force[k];
    load.torque -= (c.point[k] - walls.rotation_center(c.wall[k])).cross(c.force[k]);
    load.torque -= c.rolling_torque[k];
  }
}

}  // namespace dem

#include "engine/forces.h"

#include <cmath>
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

/// A particle's velocity and spin as its dashpots see them (DashpotVelocity): the half-step values, or
/// with the second half kick of the previous forces added, as kick() would apply it.
struct DampedMotion {
  Vec3 velocity;
  Vec3 angular_velocity;
};

DampedMotion damped_motion(const State& s, ParticleIndex p, Real h, const DashpotVelocity& d) {
  DampedMotion m{s.velocity[p], s.angular_velocity[p]};
  const Real inv_m = s.inv_mass[p];
  if (!d.predicted || inv_m == 0) return m;
  m.velocity += (0.5 * h) * (inv_m * s.force[p] + d.gravity);
  if (d.dimension == 2) m.velocity.z() = 0;
  m.angular_velocity += (0.5 * h * s.inv_inertia[p]) * s.torque[p];
  return m;
}

/// Fills the dashpot rates of `kin` from the relative contact-point velocity `u` and relative spin
/// `w_rel` (without the spin about n) the dashpots see.
void set_dashpot_rates(ContactKinematics& kin, const Vec3& u, const Vec3& w_rel) {
  kin.dashpot_overlap_rate = -u.dot(kin.normal);
  kin.dashpot_tangential_velocity = u + kin.dashpot_overlap_rate * kin.normal;
  kin.dashpot_rolling_velocity = w_rel;
}

template <class Law>
void pair_forces(const State& s, const MaterialTable& materials, PairContacts& c, Real h, const DashpotVelocity& d) {
  DEM_ASSERT(c.parts.friction == Law::friction && c.parts.rolling == Law::rolling);
  const bool books = c.parts.books;
  parallel_for(c.size(), [&](std::size_t k) {
    const ParticleIndex i = c.i[k], j = c.j[k];
    const auto [n, dist] = pair_normal(s, i, j);
    const Real overlap = s.radius[i] + s.radius[j] - dist;
    const Real arm_i = s.radius[i] - 0.5 * overlap, arm_j = s.radius[j] - 0.5 * overlap;  // as gather_forces
    Vec3 u = s.velocity[i] - s.velocity[j];
    Vec3 w_rel = Vec3::Zero();
    if constexpr (Law::uses_rotation) {
      // Contact-point velocities: omega_i x (-a_i n) - omega_j x (a_j n) (PHYSICS.md 1.3).
      u -= (arm_i * s.angular_velocity[i] + arm_j * s.angular_velocity[j]).cross(n);
      w_rel = s.angular_velocity[i] - s.angular_velocity[j];
      w_rel -= w_rel.dot(n) * n;
    }
    ContactKinematics kin;
    kin.normal = n;
    kin.overlap = overlap;
    kin.previous_force = c.force[k];
    kin.overlap_rate = -u.dot(n);
    kin.tangential_velocity = u + kin.overlap_rate * n;
    kin.rolling_velocity = w_rel;
    if (d.predicted) {
      const DampedMotion a = damped_motion(s, i, h, d), b = damped_motion(s, j, h, d);
      Vec3 ud = a.velocity - b.velocity, wd = Vec3::Zero();
      if constexpr (Law::uses_rotation) {
        ud -= (arm_i * a.angular_velocity + arm_j * b.angular_velocity).cross(n);
        wd = a.angular_velocity - b.angular_velocity;
        wd -= wd.dot(n) * n;
      }
      set_dashpot_rates(kin, ud, wd);
    } else {
      set_dashpot_rates(kin, u, w_rel);
    }
    kin.onset = c.overlap[k] == 0;  // a new contact: no evaluation has stored its overlap yet
    ContactHistory history = load_history<Law>(c, k, books);
    const Real inv_m = s.inv_mass[i] + s.inv_mass[j];  // two fixed particles: no impact energy
    if (books && history.impact_energy < 0)
      history.impact_energy = inv_m > 0 ? 0.5 * kin.overlap_rate * kin.overlap_rate / inv_m : 0;
    const LawConstants constants = materials.law_constants<Law::friction, Law::rolling>(
        materials.pair_class(s.material[i], s.material[j]), s.inv_mass[i], s.inv_inertia[i], s.radius[i], s.inv_mass[j],
        s.inv_inertia[j], s.radius[j]);
    const ContactResponse r = Law::evaluate(constants, kin, history, h);
    history.normal_work += h * r.normal_power;
    history.normal_elastic = r.normal_elastic;
    store_history<Law>(c, k, books, history);
    c.overlap[k] = overlap;
    c.work[k] += h * r.power;
    c.elastic[k] = r.elastic;
    c.force[k] = r.force;
    if constexpr (Law::rolling) c.rolling_torque[k] = r.rolling_torque;
  });
}

template <class Law>
void wall_forces(const State& s, const MaterialTable& materials, const Walls& walls, WallContacts& c, Real h,
                 const DashpotVelocity& d) {
  parallel_for(c.size(), [&](std::size_t k) {
    const ParticleIndex p = c.particle[k];
    const std::uint32_t w = c.wall[k];
    WallTouch touch;
    // Contacts are rebuilt at these very positions, so touch() holds; should it not, no force.
    if (!walls.touch(w, c.feature[k], s.position[p], s.radius[p], touch)) {
      c.overlap[k] = 0;
      c.elastic[k] = 0;
      c.point[k] = s.position[p];
      c.force[k].setZero();
      c.torque[k].setZero();
      c.rolling_torque[k].setZero();
      return;
    }
    const Vec3& n = touch.normal;
    const Real arm = s.radius[p] - 0.5 * touch.overlap;
    const Vec3 point = s.position[p] - arm * n;
    const Vec3 wall_velocity = walls.velocity_at(w, point);
    Vec3 u = s.velocity[p] - wall_velocity;
    Vec3 w_rel = Vec3::Zero();
    if constexpr (Law::uses_rotation) {
      u -= arm * s.angular_velocity[p].cross(n);
      w_rel = s.angular_velocity[p] - walls.angular_velocity(w);
      w_rel -= w_rel.dot(n) * n;
    }
    ContactKinematics kin;
    kin.normal = n;
    kin.overlap = touch.overlap;
    kin.previous_force = c.force[k];
    kin.overlap_rate = -u.dot(n);
    kin.tangential_velocity = u + kin.overlap_rate * n;
    kin.rolling_velocity = w_rel;
    if (d.predicted) {
      const DampedMotion a = damped_motion(s, p, h, d);
      Vec3 ud = a.velocity - wall_velocity, wd = Vec3::Zero();
      if constexpr (Law::uses_rotation) {
        ud -= arm * a.angular_velocity.cross(n);
        wd = a.angular_velocity - walls.angular_velocity(w);
        wd -= wd.dot(n) * n;
      }
      set_dashpot_rates(kin, ud, wd);
    } else {
      set_dashpot_rates(kin, u, w_rel);
    }
    kin.onset = c.overlap[k] == 0;  // a new contact (or one whose touch failed last time)
    ContactHistory& history = c.history[k];
    if (history.impact_energy < 0) history.impact_energy = 0.5 * kin.overlap_rate * kin.overlap_rate / s.inv_mass[p];
    const LawConstants constants = materials.law_constants<Law::friction, Law::rolling>(
        materials.pair_class(s.material[p], walls.material(w)), s.inv_mass[p], s.inv_inertia[p], s.radius[p], 0, 0,
        std::numeric_limits<Real>::infinity());
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
  });
}

template <class Law>
ForceKernels kernels_for() {
  return ForceKernels{&pair_forces<Law>, &wall_forces<Law>, Law::uses_rotation};
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

Real wall_power(const Walls& walls, const WallContacts& c) {
  Real power = 0;
  for (std::size_t k = 0; k < c.size(); ++k) {
    power += c.force[k].dot(walls.velocity_at(c.wall[k], c.point[k]));
    power += c.rolling_torque[k].dot(walls.angular_velocity(c.wall[k]));
  }
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

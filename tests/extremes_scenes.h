#pragma once
// Scenes, oracles and the run audit shared by extremes_test.cpp (default suite) and
// extremes_long_test.cpp (label `long`): the numerical extremes of docs/physics.md section 9.
//
// The audit of a run is what a careful caller of the World does after every sync interval:
//  - the status of advance_sync_interval: non_finite stops the run (a clear diagnosis);
//  - a state reported ok must be finite, every position and velocity, checked here independently
//    of the World's own check;
//  - the energy books (World::energy_balance) flag growth beyond kGrowthLimit of the energy in play,
//    and World::deepest_overlap_seen flags an overlap beyond kOverlapLimit of the smaller radius at
//    any step since the start: the limits at which `dem run` stops a run (engine/cli/energy_audit.h);
//  - World::longest_step_travel_seen flags a fixed Verlet step longer than kTravelLimit radii, which
//    `dem run` warns of (a contact can be stepped over);
//  - independently of the books, the energy itself is held against the conservation law of the
//    scenes here (no moving walls, no body force): E(t) <= E0. A rise beyond kGrowthLimit E0 that
//    the books do not flag is growth that passed silently.
// Every oracle below is derived from the formulas of docs/physics.md 2.2, 4.2, 5.1, 8.2 and 8.6 or a conservation
// law; none is a number taken from the engine's output.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "engine/config.h"
#include "engine/world.h"
#include "tests/contact_scenes.h"
#include "tests/doubling_scenes.h"

namespace dem::test {

constexpr Real kGrowthLimit = 0.5;   // energy from nowhere, as a fraction of the energy in play
constexpr Real kOverlapLimit = 0.5;  // overlap, as a fraction of the smaller radius
constexpr Real kTravelLimit = 1.0;  // a fixed Verlet step, in radii of the particle
constexpr Real kEps = std::numeric_limits<Real>::epsilon();

// Error constants of velocity Verlet on one collision (contact_physics_test.cpp derives them):
// damped restitution error <= kRestitutionC omega0 h (the dashpot force jumps by c v at onset),
// undamped |e - 1| <= kUndampedC (omega0 h)^2 (trapezoidal impulse error at the two force kinks).
constexpr Real kRestitutionC = 0.3;
constexpr Real kUndampedC = 0.2;

/// How an audited run ended.
enum class Outcome {
  bounded,          ///< every interval ok, energy within its law, nothing flagged
  stopped,          ///< advance_sync_interval returned StepStatus::non_finite
  flagged_energy,   ///< the energy books flagged growth (the run stops there)
  flagged_overlap,  ///< deepest_overlap_seen flagged an overlap the linear law does not describe
  flagged_travel,   ///< longest_step_travel_seen flagged a step that can step over a contact
};

inline const char* outcome_name(Outcome o) {
  switch (o) {
    case Outcome::bounded: return "bounded";
    case Outcome::stopped: return "stopped: non_finite";
    case Outcome::flagged_energy: return "flagged: energy books show growth";
    case Outcome::flagged_overlap: return "flagged: overlap > 0.5 R";
    case Outcome::flagged_travel: return "flagged: a step longer than R";
  }
  return "?";
}

struct AuditResult {
  Outcome outcome = Outcome::bounded;
  long intervals = 0;       // intervals completed with status ok
  long non_finite_ok = 0;   // intervals reported ok with a non-finite position or velocity
  long silent_growth = 0;   // intervals with E - E0 > kGrowthLimit E0 that the books did not flag
  Real max_rise = 0;        // max (E - E0) / E0 over the ok intervals
  Real max_change = 0;      // max |E - E0| / E0 over the ok intervals
  Real max_book_error = 0;  // max energy_balance().error / scale
  Real max_overlap = 0;     // deepest_overlap_seen().value: at any step (fraction of the radius)
  Real max_travel = 0;      // longest_step_travel_seen().value: h |v| / R of a fixed Verlet step
  Real e0 = 0;              // [J]
};

inline bool state_finite(const World& w) {
  const State& s = w.state();
  for (std::size_t p = 0; p < s.size(); ++p)
    if (!s.position[p].allFinite() || !s.velocity[p].allFinite() || !s.angular_velocity[p].allFinite()) return false;
  return true;
}

/// Runs up to `intervals` sync intervals under the audit above. An energy flag ends the run (as
/// `dem run` would) unless `stop_on_flag` is false; an overlap flag never ends it (the tunnelling
/// checks need to see where the particle ends). The first flag is the outcome.
inline AuditResult run_audited(World& w, long intervals, bool stop_on_flag = true) {
  AuditResult r;
  r.e0 = w.energies().total();
  const Real e_scale = std::abs(r.e0) > 0 ? std::abs(r.e0) : 1;
  bool flagged = false;
  for (long s = 0; s < intervals; ++s) {
    if (w.advance_sync_interval() != StepStatus::ok) {
      if (!flagged) r.outcome = Outcome::stopped;
      return r;
    }
    ++r.intervals;
    r.max_travel = w.longest_step_travel_seen().value;
    if (!state_finite(w)) {
      ++r.non_finite_ok;
      return r;
    }
    const EnergyBalance b = w.energy_balance();
    const bool energy_flag = !(b.error <= kGrowthLimit * b.scale);  // a NaN flags
    const Real rise = (w.energies().total() - r.e0) / e_scale;
    r.max_rise = std::max(r.max_rise, rise);
    r.max_change = std::max(r.max_change, std::abs(rise));
    if (std::isfinite(b.error / b.scale)) r.max_book_error = std::max(r.max_book_error, b.error / b.scale);
    const Real overlap = w.deepest_overlap_seen().value;
    r.max_overlap = std::max(r.max_overlap, overlap);
    if (!(rise <= kGrowthLimit) && !energy_flag) ++r.silent_growth;
    if (energy_flag && !flagged) {
      flagged = true;
      r.outcome = Outcome::flagged_energy;
      if (stop_on_flag) return r;
    }
    if (overlap > kOverlapLimit && !flagged) {
      flagged = true;
      r.outcome = Outcome::flagged_overlap;
    }
    if (r.max_travel > kTravelLimit && !flagged) {
      flagged = true;
      r.outcome = Outcome::flagged_travel;
    }
  }
  return r;
}

/// Round-off budget for the relative change of a momentum after `updates` velocity updates: each
/// rounds a velocity by at most eps |v|, and the roundings add up like a random walk.
inline Real momentum_budget(std::uint64_t updates) {
  return 4 * kEps * std::sqrt(static_cast<Real>(std::max<std::uint64_t>(updates, 1)));
}

/// The audit's verdict: never NaN in an ok state, never energy growth the books did not flag.
inline bool sound(const AuditResult& r) { return r.non_finite_ok == 0 && r.silent_growth == 0; }

inline void expect_sound(const AuditResult& r) {
  EXPECT_EQ(r.non_finite_ok, 0) << "a non-finite position or velocity in a state reported ok";
  EXPECT_EQ(r.silent_growth, 0) << "the energy rose by more than " << kGrowthLimit << " E0 (max rise " << r.max_rise
                                << " E0) in " << r.silent_growth << " intervals the energy books did not flag";
}

// ---------------------------------------------------------------------------------------------
// Steppers

struct Stepper {
  Method method = Method::verlet;
  Control control = Control::fixed;
  bool particle_levels = false;  // under doubling: a level per particle (docs/physics.md 6.10)
};

inline const char* method_name(Method m) { return m == Method::exact ? "exact" : "verlet"; }

inline std::string stepper_name(Stepper s) {
  return std::string(method_name(s.method)) + (s.control == Control::doubling ? " / doubling" : " / fixed") +
         (s.particle_levels ? ", levels per particle" : "");
}

/// Under doubling: level_max 0 at dt (the sync interval), down to `level_min`.
inline void apply(WorldConfig& c, Stepper s, Real dt, int level_min = -20, Real tolerance = 1e-6) {
  c.integrator.method = s.method;
  c.integrator.dt = dt;
  if (s.control == Control::doubling) set_doubling(c, dt, level_min, 0, tolerance);
  c.integrator.particle_levels = s.particle_levels;
}

/// The finest level with accepted steps (level_max when nothing was demoted).
inline int finest_level(const World& w) {
  const std::vector<std::uint64_t>& h = w.counters().level_histogram;
  for (std::size_t l = 0; l < h.size(); ++l)
    if (h[l] > 0) return static_cast<int>(l) + w.config().integrator.level_min;
  return 0;
}

// ---------------------------------------------------------------------------------------------
// Oracles (docs/physics.md 2.2 and 5.1, independent of engine/damping.cpp and engine/propagator.cpp)

/// Restitution for damping ratio zeta; the overlap convention has no rebound for zeta >= 1.
inline Real restitution_oracle(Real zeta, Separation sep) {
  if (sep == Separation::overlap && zeta >= 1) return 0;
  return oracle_from_ratio(zeta, sep).restitution;
}

/// omega0 t_c (docs/physics.md 2.2), infinite where the overlap convention never separates.
inline Real contact_time_oracle(Real zeta, Separation sep) {
  if (sep == Separation::overlap && zeta >= 1) return std::numeric_limits<Real>::infinity();
  return oracle_from_ratio(zeta, sep).time;
}

/// Overlap rate d delta / dt at time t after onset of the free oscillator delta'' + 2 beta delta' +
/// omega0^2 delta = 0, delta(0) = 0, delta'(0) = v: the overlap convention while the contact lasts.
/// Written to avoid cancellation next to zeta = 1 and overflow for strong damping (docs/physics.md 5.1).
inline Real overlap_rate_oracle(Real zeta, Real omega0, Real v, Real t) {
  const Real beta = zeta * omega0;
  const Real one_minus = (1 - zeta) * (1 + zeta);  // 1 - zeta^2 without cancellation
  if (zeta < 1) {
    const Real wd = omega0 * std::sqrt(one_minus);
    return v * std::exp(-beta * t) * (std::cos(wd * t) - beta * std::sin(wd * t) / wd);
  }
  if (zeta == 1) return v * std::exp(-beta * t) * (1 - beta * t);
  const Real s = omega0 * std::sqrt(-one_minus);
  const Real slow = omega0 * omega0 / (beta + s);  // beta - s
  return 0.5 * v * ((1 - beta / s) * std::exp(-slow * t) + (1 + beta / s) * std::exp(-(beta + s) * t));
}

// ---------------------------------------------------------------------------------------------
// Scenes

/// A particle (radius r, mass m) at distance r + gap from the plane x = 0 (normal +x), moving
/// towards it at v.
inline WorldConfig wall_impact(Method method, Real k, Damping damping, Real dt, Real r, Real m, Real v, Real gap) {
  WorldConfig c = base_config(dt);
  c.integrator.method = method;
  c.contacts[0].normal_stiffness = k;
  c.contacts[0].normal_damping = damping;
  c.walls.push_back(plane(Vec3::Zero(), Vec3::UnitX()));
  c.particles.push_back(particle(Vec3(r + gap, 0, 0), Vec3(-v, 0, 0), r, m));
  return c;
}

/// Two particles of radius r with `gap` between their surfaces: id 0 (mass m1) on the left moving at
/// +v, id 1 (mass m2, infinite allowed: inverse mass 0) on the right at rest.
inline WorldConfig pair_impact(Method method, Real k, Damping damping, Real dt, Real r, Real m1, Real m2, Real v,
                               Real gap) {
  WorldConfig c = base_config(dt);
  c.integrator.method = method;
  c.contacts[0].normal_stiffness = k;
  c.contacts[0].normal_damping = damping;
  c.particles.push_back(particle(Vec3(-r - 0.5 * gap, 0, 0), Vec3(v, 0, 0), r, m1));
  c.particles.push_back(particle(Vec3(r + 0.5 * gap, 0, 0), Vec3::Zero(), r, m2));
  return c;
}

/// Restitution of pair_impact: relative velocity after over the approach speed v.
inline Real pair_restitution(const World& w, Real v) { return (w.velocity(1).x() - w.velocity(0).x()) / v; }

/// An undamped particle bouncing between the planes x = -(r + 3 delta) and x = r + 3.70 delta
/// (delta = v / omega0 its largest overlap): incommensurate flights, contacts at every phase of a step.
inline WorldConfig between_walls(Method method, Real k, Real dt, Real r, Real m, Real v) {
  WorldConfig c = base_config(dt);
  c.integrator.method = method;
  c.contacts[0].normal_stiffness = k;
  const Real reach = v / std::sqrt(k / m);
  c.walls.push_back(plane(Vec3(-r - 3 * reach, 0, 0), Vec3::UnitX()));
  c.walls.push_back(plane(Vec3(r + 3 * reach * 1.2345678, 0, 0), -Vec3::UnitX()));
  c.particles.push_back(particle(Vec3::Zero(), Vec3(v, 0, 0), r, m));
  return c;
}

/// Where an impact ended: on the side it came from and moving away, or through its target.
struct ImpactEnd {
  Real side;      // wall: centre x; pair: x1 - x0 [m]; > 0 on the correct side
  Real rate;      // wall: v_x; pair: v1 - v0 [m/s]; > 0 moving apart
  Real restitution;  // rate / v_in
  bool passed_through() const { return !(side > 0 && rate > 0); }
};

enum class Target { wall, particle };

inline const char* target_name(Target t) { return t == Target::wall ? "wall" : "particle"; }

inline ImpactEnd impact_end(const World& w, Target t, Real v_in) {
  if (t == Target::wall) return {w.position(0).x(), w.velocity(0).x(), w.velocity(0).x() / v_in};
  const Real rate = w.velocity(1).x() - w.velocity(0).x();
  return {w.position(1).x() - w.position(0).x(), rate, rate / v_in};
}

/// An undamped impact of a particle (m = 0.01 kg, R = 1 cm) on the plane x = 0 or on an equal particle
/// at rest, at approach speed v, from a gap of `gap`, followed for `time` seconds.
struct Impact {
  ImpactEnd end;
  AuditResult audit;
  Real omega0;
};

inline Impact run_impact(Target target, Stepper s, Real k, Real v, Real dt, Real gap, Real time, Real r = 0.01,
                         Real m = 0.01) {
  WorldConfig c = target == Target::wall ? wall_impact(s.method, k, Damping{}, dt, r, m, v, gap)
                                         : pair_impact(s.method, k, Damping{}, dt, r, m, m, v, gap);
  apply(c, s, dt);
  World w(c);
  const long intervals = std::max(3L, static_cast<long>(std::ceil(time / w.sync_interval())));
  Impact out;
  out.audit = run_audited(w, intervals, false);
  out.end = impact_end(w, target, v);
  out.omega0 = std::sqrt(k / (target == Target::wall ? m : 0.5 * m));
  return out;
}

// ---------------------------------------------------------------------------------------------
// Stability sweep (docs/physics.md 4.2): dt = f x the Cundall-Strack limit 2 sqrt(m*/k) of the scene.

enum class CundallScene { pair, walls, packing };

inline const char* scene_name(CundallScene s) {
  switch (s) {
    case CundallScene::pair: return "head-on pair, undamped";
    case CundallScene::walls: return "particle between two walls, undamped";
    case CundallScene::packing: return "36-disc packing in a box, undamped";
  }
  return "?";
}

struct CundallRun {
  AuditResult audit;
  Real omega_h = 0;          // omega h at the step of the run (level_max under doubling)
  Real omega_h_finest = 0;   // omega h at the finest level used
  Real restitution = 0;      // pair only
  std::uint64_t particle_steps = 0;
};

/// The pair: two 10 g, 1 cm spheres at 0.1 m/s, k = 1e4 N/m (m* = 5 g); the particle between walls:
/// 10 g at 0.1 m/s, k = 1e4 (m* = m); the packing of contact_scenes.h, whose limit is taken with the
/// rigorous bound omega_max^2 <= max_i sum_j k/m*_ij (docs/physics.md 4.2), evaluated at t = 0.
/// Doubling: level_max at that step, level_min 12 levels below, tolerance 1e-4.
inline CundallRun run_cundall(CundallScene scene, Stepper s, Real f, long intervals, Real zeta = 0) {
  const Real k = 1e4, m = 0.01, r = 0.01, v = 0.1;
  WorldConfig c;
  Real omega = 0;
  switch (scene) {
    case CundallScene::pair:
      c = pair_impact(s.method, k, Damping{DampingKind::damping_ratio, zeta}, 1, r, m, m, v, 1e-4);
      omega = std::sqrt(k / (0.5 * m));
      break;
    case CundallScene::walls:
      c = between_walls(s.method, k, 1, r, m, v);
      omega = std::sqrt(k / m);
      break;
    case CundallScene::packing: {
      c = packing_config(s.method);
      const World probe(c);
      omega = omega_max_bound(probe);
      break;
    }
  }
  const Real dt = f * 2 / omega;
  apply(c, s, dt, -12, 1e-4);
  World w(c);
  CundallRun out;
  out.audit = run_audited(w, intervals, true);
  out.omega_h = omega * dt;
  out.omega_h_finest = omega * std::ldexp(dt, finest_level(w));
  if (scene == CundallScene::pair) out.restitution = pair_restitution(w, v);
  out.particle_steps = w.counters().particle_steps;
  return out;
}

// ---------------------------------------------------------------------------------------------
// Runs shared by the default and the long suite

inline const std::vector<Real> decades_of_stiffness{1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9};
inline const std::vector<Real> cundall_factors{0.5, 1.0, 1.01, 2.0, 10.0};

// 1. The head-on pair of docs/physics.md 8.2 (1 kg each, m* = 0.5 kg, R = 5 cm) at 0.1 m/s closing speed
// (delta_max = v / omega0 <= 0.14 R at k = 1e2), 1 mm apart, followed until three contact times
// after onset. Returns the restitution and the momentum change.
struct PairRun {
  Real restitution;
  Real momentum_error;  // |P - P0| / P0
  AuditResult audit;
  int finest;
  std::uint64_t particle_steps;
};

inline PairRun head_on_pair(Stepper s, Real k, Real zeta, Separation sep, Real dt) {
  const Real m = 1, r = 0.05, v = 0.1, gap = 1e-3;
  WorldConfig c = pair_impact(s.method, k, Damping{DampingKind::damping_ratio, zeta}, dt, r, m, m, v, gap);
  c.model.separation = sep;
  apply(c, s, dt, -20, 1e-6);
  World w(c);
  const Real omega0 = std::sqrt(k / 0.5);
  const Real span = gap / v + 3 * contact_time_oracle(zeta, sep) / omega0;
  PairRun out;
  out.audit = run_audited(w, static_cast<long>(std::ceil(span / w.sync_interval())) + 3);
  out.restitution = pair_restitution(w, v);
  out.momentum_error = std::abs(w.linear_momentum().x() - m * v) / (m * v);
  out.finest = finest_level(w);
  out.particle_steps = w.counters().particle_steps;
  return out;
}

// 2. A 10 g, 1 cm sphere at 0.1 m/s against a partner of mass M at rest (or the plane x = 0), k = 1e4,
// zeta = 0.1; Verlet at omega0 h = 0.05 (omega0 with m* = m), the exact stepper at 0.7. Followed for
// 10 / omega0 after onset.
struct LightOnHeavy {
  Real light_velocity;  // final x velocity of the light particle [m/s]
  Real heavy_velocity;  // [m/s]
  Real heavy_shift;     // displacement of the heavy particle [m]
  Real momentum_error;  // |sum m v - m v0| / (m v0), every finite mass included
  Real restitution;     // relative
  AuditResult audit;
  std::uint64_t particle_steps;
};

inline constexpr Real light_m = 0.01, light_r = 0.01, light_v = 0.1, light_k = 1e4, light_zeta = 0.1, light_gap = 1e-3;

inline Real light_dt(Method method, Real m_star) {
  return (method == Method::exact ? 0.7 : 0.05) / std::sqrt(light_k / m_star);
}

inline LightOnHeavy light_on(Method method, Real heavy_mass, bool wall) {
  const Real m_star = std::isinf(heavy_mass) || wall ? light_m : 1 / (1 / light_m + 1 / heavy_mass);
  const Real dt = light_dt(method, m_star);
  const Damping d{DampingKind::damping_ratio, light_zeta};
  WorldConfig c;
  if (wall) {
    c = wall_impact(method, light_k, d, dt, light_r, light_m, light_v, light_gap);
    c.particles[0].velocity = Vec3(light_v, 0, 0);  // moving +x, like the pair's light particle
    c.particles[0].position = Vec3(-light_r - light_gap, 0, 0);
    c.walls[0] = plane(Vec3::Zero(), -Vec3::UnitX());
  } else {
    c = pair_impact(method, light_k, d, dt, light_r, light_m, heavy_mass, light_v, light_gap);
    c.particles[0].position.x() = -light_r - light_gap;  // the same gap to x = 0 as the wall's
    c.particles[1].position.x() = light_r;
  }
  World w(c);
  const Vec3 heavy_start = wall ? Vec3::Zero() : w.position(1);
  const long n = static_cast<long>(std::ceil((light_gap / light_v + 10 / std::sqrt(light_k / m_star)) / dt)) + 5;
  LightOnHeavy out;
  out.audit = run_audited(w, n);
  out.light_velocity = w.velocity(0).x();
  out.heavy_velocity = wall ? 0 : w.velocity(1).x();
  out.heavy_shift = wall ? 0 : (w.position(1) - heavy_start).norm();
  const Real heavy_momentum = wall || std::isinf(heavy_mass) ? 0 : heavy_mass * out.heavy_velocity;
  out.momentum_error = std::abs(light_m * out.light_velocity + heavy_momentum - light_m * light_v) / (light_m * light_v);
  out.restitution = (out.heavy_velocity - out.light_velocity) / light_v;
  out.particle_steps = w.counters().particle_steps;
  return out;
}

// 3. The 10 g, 1 cm sphere on the plane x = 0 (m* = m, omega0 = 1e3 1/s) at 0.1 m/s, onset at
// omega0 t = 1, followed until omega0 t = 201.
struct WallDamped {
  Real restitution;   // v_x at the end / v
  Real rate_error;    // overlap convention: |v_x - (-delta'(T))| / v against the closed form
  bool in_contact;    // the contact is still in the list at the end
  AuditResult audit;
};

inline WallDamped damped_on_wall(Method method, Real zeta, Separation sep, Real w0h) {
  const Real k = 1e4, m = 0.01, r = 0.01, v = 0.1, omega0 = std::sqrt(k / m), gap = v / omega0;
  WorldConfig c = wall_impact(method, k, Damping{DampingKind::damping_ratio, zeta}, w0h / omega0, r, m, v, gap);
  c.model.separation = sep;
  World w(c);
  WallDamped out;
  out.audit = run_audited(w, static_cast<long>(std::ceil(201 / w0h)));
  out.restitution = w.velocity(0).x() / v;
  const Real t = w.time() - gap / v;
  out.rate_error = std::abs(w.velocity(0).x() + overlap_rate_oracle(zeta, omega0, v, t)) / v;
  out.in_contact = w.wall_contacts().size() == 1;
  return out;
}

inline const std::vector<Real> extreme_ratios{0.0, 1 - 1e-8, 1.0, 1 + 1e-8, 1e3};

// 5. Tolerances.
struct ToleranceRun {
  Real error;  // max over the onset phases of |e - e_oracle|
  std::uint64_t forced, particle_steps;  // summed over the phases
  AuditResult audit;  // of the phase with the largest error
};

// The damped wall impact (zeta = 0.1, omega0 = 1e3) under doubling: dt_base = 4 / omega0 (beyond the
// limit), level_min -16 (omega0 h_min = 6.1e-5), 40 intervals. A single run's error depends on where
// the onset falls in the step pattern, and errors at onset and release cancel by chance (docs/physics.md
// 8.6): the error of a tolerance is the maximum over `phases` onset times spread over a base step.
inline constexpr int tol_level_min = -16;
inline constexpr long tol_intervals = 40;

inline ToleranceRun tolerance_run(Method method, Real tolerance, int phases = 8) {
  const Real k = 1e4, m = 0.01, r = 0.01, v = 0.1, omega0 = std::sqrt(k / m), dt_base = 4 / omega0;
  ToleranceRun out{0, 0, 0, {}};
  for (int phase = 0; phase < phases; ++phase) {
    const Real gap = v * dt_base * (0.1 + static_cast<Real>(phase) / phases);
    WorldConfig c = wall_impact(method, k, Damping{DampingKind::damping_ratio, 0.1}, 1, r, m, v, gap);
    set_doubling(c, dt_base, tol_level_min, 0, tolerance);
    World w(c);
    const AuditResult a = run_audited(w, tol_intervals);
    const Real error = std::abs(w.velocity(0).x() / v - restitution_oracle(0.1, Separation::force_zero));
    if (phase == 0 || !(error <= out.error)) {
      out.error = error;
      out.audit = a;
    }
    if (a.intervals != tol_intervals || !sound(a)) out.audit = a;  // a run that did not end or was unsound
    out.forced += w.counters().forced_steps;
    out.particle_steps += w.counters().particle_steps;
  }
  return out;
}

// 6. The undamped 10 g, 1 cm sphere on a wall or an equal sphere, k = 1e3 N/m, approach speed
// v = ratio x omega0 R: the linear law's largest overlap is ratio x R.
struct DeepConfig {
  Stepper stepper;
  Real omega_dt;  // omega0 x the step (level_max under doubling)
};

inline const std::vector<DeepConfig> deep_configs{
    {{Method::verlet, Control::fixed}, 0.02},   {{Method::exact, Control::fixed}, 0.02},
    {{Method::exact, Control::fixed}, 1.0},     {{Method::exact, Control::fixed}, 10.0},
    {{Method::verlet, Control::doubling}, 1.0}, {{Method::verlet, Control::doubling, true}, 1.0},
    {{Method::exact, Control::doubling}, 10.0}};

inline Impact deep_impact(Target target, DeepConfig config, Real ratio) {
  const Real k = 1e3, m = 0.01, r = 0.01;
  const Real omega0 = std::sqrt(k / (target == Target::wall ? m : 0.5 * m)), v = ratio * omega0 * r, gap = 1e-3;
  return run_impact(target, config.stepper, k, v, config.omega_dt / omega0, gap, gap / v + 6 / omega0, r, m);
}

// Tunnelling: k = 1e6 (delta_max = 0.1 R at v = 10 m/s), the step carries the particle 1.5, 3 or 30
// diameters, starting 0.3 R from its target.
inline Impact tunnelling_impact(Target target, Stepper s, Real diameters) {
  const Real k = 1e6, m = 0.01, r = 0.01, v = 10, gap = 0.3 * r;
  const Real dt = diameters * 2 * r / v;
  return run_impact(target, s, k, v, dt, gap, 6 * dt, r, m);
}

// 7. Levels.
struct LevelsRun {
  bool clock_exact = true;   // interval count, tick 0 and time n T after every interval
  bool ticks_covered = true;  // sum over levels of accepted steps x their ticks = particles x n x 2^levels
  Real free_error = 0;       // |x - (x0 + v t)| of the free particle [m]
  Real energy_change = 0;    // max |E - E0| / E0 of the bouncing one
  int finest = 0;
  std::uint64_t forced = 0;
  AuditResult audit;
};

// A particle bouncing between two walls (k = 1e6, 10 g, 1 m/s: the contact needs omega0 h ~ 0.01,
// about level -8 at dt_base = 2^-12 s) and a free particle 10 m away at 0.37 m/s, under doubling with
// level_max 0 and level_min = -levels, tolerance 1e-6.
inline LevelsRun levels_run(Method method, int levels, long intervals) {
  WorldConfig c = between_walls(method, 1e6, 1, 0.01, 0.01, 1);
  c.particles.push_back(particle(Vec3(10, 0, 0), Vec3(0.37, -0.21, 0.13), 0.01, 0.01));
  set_doubling(c, 0x1p-12, -levels, 0, 1e-6);
  World w(c);
  const Vec3 x0 = w.position(1), v0 = w.velocity(1);
  const Real e0 = 0.5 * 0.01 * 1.0;  // the bouncing particle's kinetic energy [J]
  LevelsRun out;
  const Real period = w.sync_interval();
  for (long n = 1; n <= intervals; ++n) {
    if (w.advance_sync_interval() != StepStatus::ok) {
      out.audit.outcome = Outcome::stopped;
      break;
    }
    ++out.audit.intervals;
    out.clock_exact = out.clock_exact && w.clock().interval == n && w.clock().tick == 0 &&
                      w.time() == static_cast<Real>(n) * period;
    const Real t = static_cast<Real>(n) * period;
    out.free_error = std::max(out.free_error, (w.position(1) - (x0 + v0 * t)).norm());
    const Energies e = w.energies();
    out.energy_change = std::max(out.energy_change, std::abs(e.kinetic + e.elastic - e0 - 0.5 * 0.01 * v0.squaredNorm()) / e0);
    if (!state_finite(w)) ++out.audit.non_finite_ok;
  }
  // Integer time: every particle covered exactly 2^levels ticks per interval.
  const std::vector<std::uint64_t>& h = w.counters().level_histogram;
  std::uint64_t ticks = 0;
  for (std::size_t l = 0; l < h.size(); ++l) ticks += h[l] << l;
  out.ticks_covered = ticks == 2 * static_cast<std::uint64_t>(out.audit.intervals) << levels;
  out.finest = finest_level(w);
  out.forced = w.counters().forced_steps;
  return out;
}

// 8. Undamped contacts dissipate nothing: World::dissipated_energy() must stay within the integrator's
// energy error, and energy_balance() must not report growth. The particle between two walls,
// k = 1e6, 1 kg, 1 m/s (about one contact per 100 steps at omega0 h = 0.1).
struct BooksRun {
  Real dissipated;    // World::dissipated_energy() / E0
  Real book_error;    // energy_balance().error / scale
  Real energy_error;  // max |E - E0| / E0
  long contacts;
};

/// Between the walls of between_walls, a second equal particle coming the other way: pair contacts
/// as well as wall contacts, unevenly spaced so the two kinds never coincide.
inline WorldConfig pair_between_walls(Method method, Real k, Real dt, Real r, Real m, Real v) {
  WorldConfig c = between_walls(method, k, dt, r, m, v);
  const Real reach = v / std::sqrt(k / m);
  c.walls[0] = plane(Vec3(-2.05 * r - 3 * reach, 0, 0), Vec3::UnitX());
  c.walls[1] = plane(Vec3(2.07 * r + 3 * reach * 1.2345678, 0, 0), -Vec3::UnitX());
  c.particles[0].position = Vec3(-1.05 * r, 0, 0);
  c.particles.push_back(particle(Vec3(1.07 * r, 0, 0), Vec3(-v, 0, 0), r, m));
  return c;
}

/// An undamped Verlet or exact run of `steps` intervals of one sphere between two walls, or (`pair`)
/// two spheres that also hit each other: contacts counted, energy error and the books. omega0 h is
/// w0h for the stiffest contact (the pair's, m* = m / 2, when there is one).
inline BooksRun books_run(Method method, Real w0h, long steps, bool pair = false) {
  const Real k = 1e6, m = 1, v = 1, dt = w0h / std::sqrt(k / (pair ? 0.5 * m : m));
  World w(pair ? pair_between_walls(method, k, dt, 0.05, m, v) : between_walls(method, k, dt, 0.05, m, v));
  const Real e0 = (pair ? 2 : 1) * 0.5 * m * v * v;
  BooksRun out{0, 0, 0, 0};
  std::size_t touching = 0;
  for (long s = 0; s < steps; ++s) {
    EXPECT_EQ(w.advance_sync_interval(), StepStatus::ok);
    const std::size_t now = w.wall_contacts().size() + w.pair_contacts().size();
    out.contacts += static_cast<long>(now > touching ? now - touching : 0);
    touching = now;
    out.energy_error = std::max(out.energy_error, std::abs(w.energies().total() - e0) / e0);
  }
  out.dissipated = w.dissipated_energy() / e0;
  const EnergyBalance b = w.energy_balance();
  out.book_error = b.error / b.scale;
  return out;
}

// ---------------------------------------------------------------------------------------------
// Summary table of the long suite: Markdown, one row per case, one section per test. Each test
// process (ctest runs every test alone) merges its section into the file under an exclusive lock
// and replaces the file atomically, so the table holds the last result of every section.

struct TableRow {
  std::string case_name;
  std::string parameters;
  std::string stepper;
  std::string outcome;
  std::string figure;  // measured figure against its bound, and the verdict
};

inline std::string fmt(const char* format, double a) {
  char buffer[96];
  std::snprintf(buffer, sizeof buffer, format, a);
  return buffer;
}

inline std::string fmt(const char* format, double a, double b) {
  char buffer[160];
  std::snprintf(buffer, sizeof buffer, format, a, b);
  return buffer;
}

/// "measured <= bound (ok)" or "(FAIL)"; known engine failures say so.
inline std::string verdict(const std::string& what, double measured, double bound, bool known_failure = false) {
  const bool ok = measured <= bound;
  return what + " " + fmt("%.3g", measured) + " <= " + fmt("%.3g", bound) +
         (ok ? " (ok)" : known_failure ? " (FAIL, known engine failure)" : " (FAIL)");
}

inline std::string table_path() {
  const char* env = std::getenv("DEM_EXTREMES_TABLE");
  return env != nullptr && *env != '\0' ? std::string(env) : std::string("extremes_summary.md");
}

/// Writes (or replaces) section `title` of the summary table; `order` places it among the others.
inline void publish_section(int order, const std::string& title, const std::vector<TableRow>& rows) {
  const std::string path = table_path();
  const int lock = ::open((path + ".lock").c_str(), O_CREAT | O_RDWR, 0644);
  if (lock >= 0) ::flock(lock, LOCK_EX);
  // Sections already in the file, by their marker line "<!-- section NN: title -->".
  std::map<std::string, std::string> sections;
  {
    std::ifstream in(path);
    std::string line, key, body;
    while (std::getline(in, line)) {
      if (line.rfind("<!-- section ", 0) == 0) {
        if (!key.empty()) sections[key] = body;
        key = line;
        body.clear();
      } else if (!key.empty()) {
        body += line + "\n";
      }
    }
    if (!key.empty()) sections[key] = body;
  }
  char marker[256];
  std::snprintf(marker, sizeof marker, "<!-- section %02d: %s -->", order, title.c_str());
  std::ostringstream body;
  body << "\n## " << title << "\n\n| case | parameters | stepper / control | outcome | measured vs bound |\n"
       << "|---|---|---|---|---|\n";
  for (const TableRow& r : rows)
    body << "| " << r.case_name << " | " << r.parameters << " | " << r.stepper << " | " << r.outcome << " | " << r.figure
         << " |\n";
  body << "\n";
  for (auto it = sections.begin(); it != sections.end();) {  // an older marker of the same section
    if (it->first.find(": " + title + " -->") != std::string::npos) it = sections.erase(it);
    else ++it;
  }
  sections[marker] = body.str();
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << "# Extreme-value suite (docs/physics.md section 9): summary\n\n"
        << "Written by `extremes_long_test` (ctest label `long`); one section per test, one row per case. "
        << "Outcomes: bounded (every interval ok, nothing flagged); stopped (StepStatus::non_finite); flagged: "
        << "energy books show growth (World::energy_balance error > 0.5 of the energy in play; the run stops there, "
        << "as `dem run` would) or overlap > 0.5 R (World::deepest_overlap at a sync time). Every run is also "
        << "checked for a NaN in a state reported ok and for energy growth the books did not flag.\n\n";
    for (const auto& [key, text] : sections) out << key << "\n" << text;
  }
  std::rename(tmp.c_str(), path.c_str());
  if (lock >= 0) {
    ::flock(lock, LOCK_UN);
    ::close(lock);
  }
  std::printf("summary table: section '%s' (%zu rows) written to %s\n", title.c_str(), rows.size(), path.c_str());
}

}  // namespace dem::test

#pragma once
// Scenes and oracles shared by contact_physics_test.cpp and contact_physics_long_test.cpp:
// configurations built in code (config.h structs) and the docs/physics.md 2.2 closed forms, re-derived
// here independently of engine/damping.cpp.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "engine/config.h"
#include "engine/world.h"

namespace dem::test {

// ---------------------------------------------------------------------------------------------
// Helpers: configurations built in code, oracles of docs/physics.md 2.2 re-derived independently.

// Scientific notation for RecordProperty (std::to_string prints 6 fixed decimals).
inline std::string sci(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.4e", x);
  return buffer;
}

inline WorldConfig base_config(Real dt, int dimension = 3) {
  WorldConfig c;
  c.threads = 1;
  c.model.dimension = dimension;
  c.integrator.dt = dt;
  return c;
}

inline ParticleConfig particle(const Vec3& x, const Vec3& v, Real radius, Real mass) {
  ParticleConfig p;
  p.position = x;
  p.velocity = v;
  p.radius = radius;
  p.mass = mass;
  return p;
}

inline WallConfig plane(const Vec3& point, const Vec3& normal) {
  WallConfig w;
  w.kind = WallKind::plane;
  w.point = point;
  w.normal = normal.normalized();
  return w;
}

// Advances exactly n steps (no float comparison of times).
inline void advance(World& world, long n) {
  for (long s = 0; s < n; ++s) ASSERT_EQ(world.advance_sync_interval(), StepStatus::ok);
}

// Oracle of docs/physics.md 2.2, written independently of engine/damping.cpp.
// omega0 * t_c and e for damping ratio zeta in each convention.
struct ContactOracle {
  Real time;  // omega0 t_c
  Real restitution;
};

inline ContactOracle oracle_from_ratio(Real zeta, Separation sep) {
  if (zeta == 0) return {pi, 1};
  if (sep == Separation::overlap) {
    const Real wd = std::sqrt(1 - zeta * zeta);
    return {pi / wd, std::exp(-zeta * pi / wd)};
  }
  Real t;
  if (zeta < 1) {
    const Real wd = std::sqrt(1 - zeta * zeta);
    t = (pi - 2 * std::atan(zeta / wd)) / wd;
  } else if (zeta == 1) {
    t = 2;
  } else {
    const Real s = std::sqrt(zeta * zeta - 1);
    t = std::log((zeta + s) / (zeta - s)) / s;
  }
  return {t, std::exp(-zeta * t)};
}

// zeta giving restitution e: closed form (overlap), bisection on the monotone e(zeta) (force-zero).
inline Real oracle_ratio_from_restitution(Real e, Separation sep) {
  if (e >= 1) return 0;
  const Real l = std::log(e);
  if (sep == Separation::overlap) return -l / std::sqrt(pi * pi + l * l);
  Real lo = 0, hi = 50;
  for (int it = 0; it < 200; ++it) {
    const Real mid = 0.5 * (lo + hi);
    if (oracle_from_ratio(mid, sep).restitution > e) lo = mid;
    else hi = mid;
  }
  return 0.5 * (lo + hi);
}

// ---------------------------------------------------------------------------------------------
// 6.2 Head-on collision of two equal spheres, no gravity

struct Collision {
  Real restitution;    // -(v_rel . n after) / (v_rel . n before)
  Real contact_time;   // [s], onset known exactly (free flight), end at mid-sample
  Real max_overlap;    // [m], maximum over the samples
  Real time_of_max;    // [s] since onset
};

// Two spheres of mass m, radius r approach along x with relative speed v; onset after
// (onset_steps + phase) steps. Force-zero: the contact ends when the force record goes to zero;
// overlap: when the pair contact disappears. Both are sampled at step ends.
inline Collision head_on(Real k, Damping damping, Separation sep, Real dt, Real v = 1.0, Real phase = 0.37,
                  long onset_steps = 5, Real m = 1.0, Real r = 0.05) {
  WorldConfig c = base_config(dt);
  c.model.separation = sep;
  c.contacts[0].normal_stiffness = k;
  c.contacts[0].normal_damping = damping;
  const Real gap = v * (static_cast<Real>(onset_steps) + phase) * dt;
  c.particles.push_back(particle(Vec3(-(r + 0.5 * gap), 0, 0), Vec3(0.5 * v, 0, 0), r, m));
  c.particles.push_back(particle(Vec3(r + 0.5 * gap, 0, 0), Vec3(-0.5 * v, 0, 0), r, m));
  World world(c);
  const Real t_on = gap / v;
  Real t_last = -1, t_first_after = -1, max_overlap = 0, t_max = 0;
  bool started = false;
  for (long s = 1; s < 100'000'000; ++s) {
    EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    const Real t = dt * static_cast<Real>(s);
    const PairContacts& pc = world.pair_contacts();
    bool active = false;
    if (pc.size() > 0) {
      active = sep == Separation::overlap || pc.force[0].norm() > 0;
      if (pc.overlap[0] > max_overlap) {
        max_overlap = pc.overlap[0];
        t_max = t - t_on;
      }
    }
    if (active) {
      started = true;
      t_last = t;
    } else if (started) {
      t_first_after = t;
      break;
    }
  }
  advance(world, 3);
  const Real v_after = world.state().velocity[1].x() - world.state().velocity[0].x();
  return {v_after / v, 0.5 * (t_last + t_first_after) - t_on, max_overlap, t_max};
}

// ---------------------------------------------------------------------------------------------
// 6.6 Energy: an undamped particle bouncing between two walls (kinetic <-> elastic every period,
// contact made and broken twice per period). Verlet must show bounded error and no drift.

struct DriftResult {
  Real max_error;    // max |E - E0| / E0
  Real first_mean;   // mean (E - E0) / E0 over the first tenth
  Real last_mean;    // ... over the last tenth
  Real w0h;
};

inline DriftResult bounce_between_walls(long periods) {
  const Real k = 1e6, mass = 1, radius = 0.05, v = 1.0;
  const Real omega0 = std::sqrt(k / mass), w0h = 0.1, dt = w0h / omega0;
  const Real gap_left = 0.6e-3, gap_right = 0.6e-3 * 1.2345678;  // incommensurate free flights
  WorldConfig c = base_config(dt);
  c.contacts[0].normal_stiffness = k;
  c.walls.push_back(plane(Vec3(-radius - gap_left, 0, 0), Vec3::UnitX()));
  c.walls.push_back(plane(Vec3(radius + gap_right, 0, 0), -Vec3::UnitX()));
  c.particles.push_back(particle(Vec3::Zero(), Vec3(v, 0, 0), radius, mass));
  World world(c);
  const Real e0 = 0.5 * mass * v * v;
  const Real period = 2 * pi / omega0 + (gap_left + gap_right) / v;
  const long steps = static_cast<long>(static_cast<Real>(periods) * period / dt);
  const long tenth = steps / 10;
  DriftResult r{0, 0, 0, w0h};
  for (long s = 0; s < steps; ++s) {
    EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    const Energies e = world.energies();
    const Real d = (e.kinetic + e.elastic - e0) / e0;
    r.max_error = std::max(r.max_error, std::abs(d));
    if (s < tenth) r.first_mean += d / static_cast<Real>(tenth);
    if (s >= steps - tenth) r.last_mean += d / static_cast<Real>(tenth);
  }
  return r;
}

// Bounds: inside a contact velocity Verlet conserves H - (h^2/8) F^2/m, so E - E0 reaches
// (omega0 h)^2/4 of the elastic energy; each onset/separation adds a zero-mean kink error of at most
// (omega0 h)^2/8 (see kUndampedC). Bounded error: |dE| <= 0.5 (omega0 h)^2 E0. No drift: the mean
// error of the last tenth within 0.05 (omega0 h)^2 E0 of the first tenth's (a systematic loss or gain
// of 5e-8 E0 per period would exceed it after 1e4 periods).
inline void expect_no_drift(const DriftResult& r) {
  const Real w2 = r.w0h * r.w0h;
  EXPECT_LE(r.max_error, 0.5 * w2);
  EXPECT_LE(std::abs(r.last_mean - r.first_mean), 0.05 * w2);
  EXPECT_GT(r.max_error, 0.0);  // the measurement sees the contacts at all
}

// ---------------------------------------------------------------------------------------------
// 6.6 Many undamped contacts: a 2-D packing of overlapping discs in a box container, random
// velocities with the total momentum subtracted, no gravity. Energy = kinetic + elastic.

struct PackingRun {
  Real omega_max_h;       // from the bound at t = 0
  Real omega_max_h_run;   // largest bound seen during the run (sampled)
  Real max_error;         // max |E - E0| / E0
  Real min_change;        // min (E - E0) / E0
  Real first_mean;        // mean |E - E0| / E0 over the first tenth
  Real last_mean;         // ... the last tenth
  std::size_t contact_events;  // pair-count changes seen, a lower bound on makes and breaks
  Real initial_energy;    // E0 = kinetic + elastic at t = 0 [J]
  Real initial_kinetic;   // [J]
};

// omega_max^2 <= max_i sum_j k_ij / m*_ij over the current contacts (walls: m* = m_i), docs/physics.md 4.2.
inline Real omega_max_bound(const World& world) {
  const State& s = world.state();
  std::vector<Real> sum(s.size(), 0);
  const MaterialTable& m = world.materials();
  const PairContacts& pc = world.pair_contacts();
  for (std::size_t q = 0; q < pc.size(); ++q) {
    const Real k_n = m.params(m.pair_class(s.material[pc.i[q]], s.material[pc.j[q]])).k_n;
    const Real k_over_m = k_n * (s.inv_mass[pc.i[q]] + s.inv_mass[pc.j[q]]);
    sum[pc.i[q]] += k_over_m;
    sum[pc.j[q]] += k_over_m;
  }
  const WallContacts& wc = world.wall_contacts();
  for (std::size_t q = 0; q < wc.size(); ++q) {
    const Real k_n = m.params(m.pair_class(s.material[wc.particle[q]], world.walls().material(wc.wall[q]))).k_n;
    sum[wc.particle[q]] += k_n * s.inv_mass[wc.particle[q]];
  }
  return std::sqrt(*std::max_element(sum.begin(), sum.end()));
}

// Subtracts the centre-of-mass velocity, so the total momentum is zero (to round-off).
inline void remove_total_momentum(WorldConfig& c) {
  Vec3 momentum = Vec3::Zero();
  Real mass = 0;
  for (const ParticleConfig& p : c.particles) {
    momentum += p.mass * p.velocity;
    mass += p.mass;
  }
  for (ParticleConfig& p : c.particles) p.velocity -= momentum / mass;
}

// A box container centred on the origin.
inline WallConfig box_container(const Vec3& half_extents) {
  WallConfig box;
  box.kind = WallKind::box;
  box.inside = true;
  box.half_extents = half_extents;
  return box;
}

inline WorldConfig packing_config(Method method, std::uint64_t seed = 20240611) {
  const int nx = 6, ny = 6;
  const Real r0 = 0.01, spacing = 2 * r0 * 0.99;  // about 1% overlap between neighbours
  WorldConfig c = base_config(1.0, 2);
  c.integrator.method = method;
  c.contacts[0].normal_stiffness = 1e4;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<Real> u(-1, 1);
  for (int i = 0; i < nx; ++i) {
    for (int j = 0; j < ny; ++j) {
      ParticleConfig p;
      p.radius = r0 * (1 + 0.02 * u(rng));
      p.mass = 1e-3 * (1 + 0.3 * u(rng));
      p.position = Vec3((i - 0.5 * (nx - 1)) * spacing + 0.01 * r0 * u(rng),
                        (j - 0.5 * (ny - 1)) * spacing + 0.01 * r0 * u(rng), 0);
      p.velocity = Vec3(u(rng), u(rng), 0) * 0.3;
      c.particles.push_back(p);
    }
  }
  remove_total_momentum(c);
  c.walls.push_back(box_container(Vec3(0.5 * nx * spacing, 0.5 * ny * spacing, 1.0)));
  return c;
}

// A compressed, settled packing whose contacts all persist: a triangular lattice of 60 discs, each
// neighbour pair overlapping by 3% of the diameter, in a box; masses vary by +-30% so the vibration
// spectrum is not degenerate. It is settled to rest with heavy damping first (the lattice's boundary
// is not in equilibrium), then started undamped from the settled positions with random velocities
// of up to 0.2 m/s, small enough that no contact opens. Verlet then integrates a linear system: it
// conserves the shadow energy H - (h^2/8) sum_i |F_i|^2/m_i exactly, and since the net forces are zero
// at the start, 0 <= E - E0 <= (h^2/8) sum_i |F_i|^2/m_i <= (omega_max h)^2/4 * (the vibration
// energy, which is the initial kinetic energy) up to O(h^4).
inline WorldConfig persistent_packing_config(Method method) {
  const int nx = 8, ny = 8;
  const Real r0 = 0.01, compression = 0.03, speed = 0.2;
  const Real spacing = 2 * r0 * (1 - compression), row = spacing * std::sqrt(Real(3)) / 2;
  WorldConfig c = base_config(1.0, 2);
  c.integrator.method = method;
  c.contacts[0].normal_stiffness = 1e4;
  std::mt19937_64 rng(20261201);
  std::uniform_real_distribution<Real> u(-1, 1);
  for (int j = 0; j < ny; ++j) {
    const int count = j % 2 == 0 ? nx : nx - 1;  // odd rows sit in the grooves of the even ones
    for (int i = 0; i < count; ++i) {
      ParticleConfig p;
      p.radius = r0;
      p.mass = 1e-3 * (1 + 0.3 * u(rng));
      p.position = Vec3((i - 0.5 * (nx - 1) + (j % 2) * 0.5) * spacing, (j - 0.5 * (ny - 1)) * row, 0);
      p.velocity = Vec3(u(rng), u(rng), 0) * speed;
      c.particles.push_back(p);
    }
  }
  remove_total_momentum(c);
  c.walls.push_back(box_container(Vec3(0.5 * nx * spacing, 0.5 * (ny - 1) * row + 0.5 * spacing, 1.0)));

  WorldConfig settle = c;
  settle.contacts[0].normal_damping = {DampingKind::damping_ratio, 0.7};
  for (ParticleConfig& p : settle.particles) p.velocity = Vec3::Zero();
  settle.integrator.dt = 0.1 * std::sqrt(0.7e-3 / settle.contacts[0].normal_stiffness);
  World world(settle);
  for (int s = 0; s < 20'000; ++s) EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
  EXPECT_LT(world.energies().kinetic, 1e-20 * world.energies().elastic);  // settled to rest
  for (std::size_t q = 0; q < c.particles.size(); ++q) c.particles[q].position = world.position(ParticleId(q));
  return c;
}

inline PackingRun run_packing(WorldConfig c, Real omega_max_h, long steps) {
  PackingRun r{};
  {
    const World probe(c);
    const Real omega_max = omega_max_bound(probe);
    c.integrator.dt = omega_max_h / omega_max;
    r.omega_max_h = omega_max_h;
  }
  World world(c);
  EXPECT_LT(world.linear_momentum().norm(), 1e-15);
  auto energy = [&world] {
    const Energies e = world.energies();
    return e.kinetic + e.elastic;
  };
  const Real e0 = energy();
  r.initial_energy = e0;
  r.initial_kinetic = world.energies().kinetic;
  const long tenth = steps / 10;
  std::size_t pairs = world.pair_contacts().size();
  for (long s = 0; s < steps; ++s) {
    EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    const Real change = (energy() - e0) / e0;
    r.min_change = std::min(r.min_change, change);
    const Real d = std::abs(change);
    r.max_error = std::max(r.max_error, d);
    if (s < tenth) r.first_mean += d / static_cast<Real>(tenth);
    if (s >= steps - tenth) r.last_mean += d / static_cast<Real>(tenth);
    if (world.pair_contacts().size() != pairs) ++r.contact_events;
    pairs = world.pair_contacts().size();
    if (s % 64 == 0) r.omega_max_h_run = std::max(r.omega_max_h_run, omega_max_bound(world) * c.integrator.dt);
  }
  return r;
}

inline PackingRun run_packing(Method method, Real omega_max_h, long steps) {
  return run_packing(packing_config(method), omega_max_h, steps);
}

inline void record(const PackingRun& r) {
  ::testing::Test::RecordProperty("max_energy_error", sci(r.max_error));
  ::testing::Test::RecordProperty("first_tenth_mean", sci(r.first_mean));
  ::testing::Test::RecordProperty("last_tenth_mean", sci(r.last_mean));
  ::testing::Test::RecordProperty("omega_max_h_during_run", sci(r.omega_max_h_run));
  ::testing::Test::RecordProperty("contact_count_changes", std::to_string(r.contact_events));
}

}  // namespace dem::test

// An estimate of this machine's limit per particle-step on the dense bed: the physics of
// scenes/dense_bed.toml (linear spring-dashpot in the overlap convention, tangential spring with a
// Coulomb cap by LIGGGHTS' rule, gravity, the box's six planes, velocity Verlet at dt = 7.27e-6 s) in
// the least work a step can do, on one thread:
// one pass over a half list of candidate pairs that keeps each pair's tangential spring in the
// pair's own slot (LIGGGHTS' layout; no contact list rebuilt, no adjacency, no energy books, no
// checks), forces added to both particles at once, then the kick and drift. Candidates are found once
// outside the timed loop with the engine's grid (skin 2 mm; in 2,000 steps LIGGGHTS rebuilt twice),
// so neighbour search is left out of the limit. Not deterministic across thread counts and not used
// by the engine: it is a yardstick. BM_EngineDenseBed times the engine on the same particles and
// steps, so one run gives the ratio; the kinetic energy after the steps is printed beside both to
// show they integrate the same bed (chaotic in detail, equal in size).
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "bench/harness.h"
#include "broadphase/grid.h"
#include "engine/world.h"

namespace {

using dem::Real;
using dem::Vec3;

constexpr Real dt = 7.27e-6, k_n = 1e6, k_t = 285714.2857142857, gamma_n = 9535.697, gamma_t = 4767.8485;
constexpr Real friction = 0.5, skin = 0.002;
const Vec3 gravity(0, 0, -9.81);
const Vec3 box_low(0, 0, 0), box_high(0.3, 0.3, 0.4);

std::unique_ptr<dem::World> dense_bed(int threads) {
  return dem::World::load(std::string(DEM_SOURCE_DIR) + "/scenes/dense_bed.toml",
                          {"run.threads=" + std::to_string(threads)});
}

struct Bed {
  std::vector<Vec3> x, v, w, f, t;
  std::vector<Real> r, inv_m, inv_i;
  std::vector<std::uint32_t> pair_i, pair_j;  // candidate pairs, i < j
  std::vector<Vec3> pair_spring;              // tangential spring per candidate pair [m]
  std::vector<Vec3> wall_spring;              // 6 per particle: -x, +x, -y, +y, -z, +z planes [m]

  Real kinetic_energy() const {
    Real e = 0;
    for (std::size_t p = 0; p < x.size(); ++p) e += 0.5 * v[p].squaredNorm() / inv_m[p];
    return e;
  }
};

Bed bed_from(const dem::World& world) {
  const dem::State& s = world.state();
  Bed b{s.position, s.velocity, s.angular_velocity, {}, {}, s.radius, s.inv_mass, s.inv_inertia, {}, {}, {}, {}};
  b.f.assign(b.x.size(), Vec3::Zero());
  b.t.assign(b.x.size(), Vec3::Zero());
  b.wall_spring.assign(6 * b.x.size(), Vec3::Zero());
  dem::broadphase::CandidatePairs candidates;
  dem::broadphase::GridBroadphase grid;
  grid.find_pairs(b.x, b.r, skin, candidates);
  for (std::size_t i = 0; i < candidates.row_count(); ++i)
    for (std::uint32_t k = candidates.row_start[i]; k < candidates.row_start[i + 1]; ++k) {
      b.pair_i.push_back(static_cast<std::uint32_t>(i));
      b.pair_j.push_back(candidates.partner[k]);
    }
  b.pair_spring.assign(b.pair_i.size(), Vec3::Zero());
  return b;
}

// One contact with normal n (from the partner to p), overlap delta, effective mass m and relative
// surface velocity u; updates the spring and returns the force on p. The normal force follows the
// scene's overlap convention (it may pull at the end of a contact, as the engine's law and LIGGGHTS'
// default do); the tangential part is LIGGGHTS' simpler rule (the spring projected without keeping its
// length, the cap on spring plus dashpot), which costs the same as the engine's.
inline Vec3 contact_force(const Vec3& n, Real delta, Real m, const Vec3& u, Vec3& spring) {
  const Real u_n = u.dot(n);
  const Vec3 u_t = u - u_n * n;
  const Real f_n = k_n * delta - gamma_n * m * u_n;
  spring += u_t * dt;
  spring -= spring.dot(n) * n;
  Vec3 f_t = -k_t * spring - gamma_t * m * u_t;
  const Real cap = friction * std::max(f_n, Real(0)), size = f_t.norm();
  if (size > cap) {
    f_t *= cap / size;
    spring = -(f_t + gamma_t * m * u_t) / k_t;
  }
  return f_n * n + f_t;
}

void compute_forces(Bed& b) {
  const std::size_t n = b.x.size();
  for (std::size_t p = 0; p < n; ++p) {
    b.f[p] = gravity / b.inv_m[p];
    b.t[p].setZero();
  }
  for (std::size_t k = 0; k < b.pair_i.size(); ++k) {
    const std::uint32_t i = b.pair_i[k], j = b.pair_j[k];
    const Vec3 d = b.x[i] - b.x[j];
    const Real reach = b.r[i] + b.r[j], dist2 = d.squaredNorm();
    if (dist2 >= reach * reach) {
      b.pair_spring[k].setZero();
      continue;
    }
    const Real dist = std::sqrt(dist2), delta = reach - dist;
    const Vec3 normal = d / dist;
    const Real a_i = b.r[i] - 0.5 * delta, a_j = b.r[j] - 0.5 * delta;
    const Vec3 u = b.v[i] - b.v[j] - (a_i * b.w[i] + a_j * b.w[j]).cross(normal);
    const Real m = 1 / (b.inv_m[i] + b.inv_m[j]);
    const Vec3 force = contact_force(normal, delta, m, u, b.pair_spring[k]);
    b.f[i] += force;
    b.f[j] -= force;
    const Vec3 arm_torque = normal.cross(force);  // torque on i is -a_i n x F, on j -a_j n x F
    b.t[i] -= a_i * arm_torque;
    b.t[j] -= a_j * arm_torque;
  }
  for (std::size_t p = 0; p < n; ++p) {
    for (int side = 0; side < 6; ++side) {
      const int axis = side / 2;
      const bool high = side % 2 == 1;
      const Real gap = high ? box_high[axis] - b.x[p][axis] : b.x[p][axis] - box_low[axis];
      Vec3& spring = b.wall_spring[6 * p + side];
      if (gap >= b.r[p]) {
        spring.setZero();
        continue;
      }
      Vec3 normal = Vec3::Zero();
      normal[axis] = high ? -1 : 1;  // from the wall to the particle
      const Real delta = b.r[p] - gap, a = b.r[p] - 0.5 * delta;  // lever arm to mid-overlap, as the engine
      const Vec3 u = b.v[p] - (a * b.w[p]).cross(normal);
      const Vec3 force = contact_force(normal, delta, 1 / b.inv_m[p], u, spring);
      b.f[p] += force;
      b.t[p] -= a * normal.cross(force);
    }
  }
}

void kick(Bed& b) {
  for (std::size_t p = 0; p < b.x.size(); ++p) {
    b.v[p] += (0.5 * dt * b.inv_m[p]) * b.f[p];
    b.w[p] += (0.5 * dt * b.inv_i[p]) * b.t[p];
  }
}

void step(Bed& b) {
  kick(b);
  for (std::size_t p = 0; p < b.x.size(); ++p) b.x[p] += dt * b.v[p];
  compute_forces(b);
  kick(b);
}

constexpr int steps_per_iteration = 100;

void BM_LimitKernelDenseBed(benchmark::State& bench) {
  const std::unique_ptr<dem::World> world = dense_bed(1);
  Bed b = bed_from(*world);
  const std::vector<Vec3> start = b.x;
  compute_forces(b);
  const int steps = dem::bench::iterations(steps_per_iteration);
  for (auto _ : bench)
    for (int s = 0; s < steps; ++s) step(b);
  const double particle_steps = static_cast<double>(bench.iterations()) * steps * b.x.size();
  bench.counters["particle_steps_per_s"] = benchmark::Counter(particle_steps, benchmark::Counter::kIsRate);
  bench.counters["candidates_per_particle"] = static_cast<double>(b.pair_i.size()) / b.x.size();
  bench.counters["kinetic_energy_J"] = b.kinetic_energy();
  // The candidates stay complete while no particle has moved more than skin/2 since they were found.
  Real moved = 0;
  for (std::size_t p = 0; p < b.x.size(); ++p) moved = std::max(moved, (b.x[p] - start[p]).norm());
  if (moved > 0.5 * skin) bench.SkipWithError("a particle moved more than skin/2: the candidate list is stale");
  bench.counters["max_displacement_m"] = moved;
}

void BM_EngineDenseBed(benchmark::State& bench) {
  const int threads = static_cast<int>(bench.range(0));
  const std::unique_ptr<dem::World> world = dense_bed(threads);
  const int steps = dem::bench::iterations(steps_per_iteration);
  for (auto _ : bench)
    for (int s = 0; s < steps; ++s) world->advance_sync_interval();
  const double particle_steps = static_cast<double>(bench.iterations()) * steps * world->particle_count();
  bench.counters["particle_steps_per_s"] = benchmark::Counter(particle_steps, benchmark::Counter::kIsRate);
  bench.counters["kinetic_energy_J"] = world->energies().kinetic;
  bench.counters["threads"] = world->thread_count();
  char hash[32];
  std::snprintf(hash, sizeof hash, "hash=%016llx", static_cast<unsigned long long>(world->state_hash()));
  bench.SetLabel(hash);
}

// 5 iterations of 100 steps: the kinetic energies compare after the same 500 steps, within which no
// particle of the settling bed moves half the skin (over 1,000 steps one does: the kernel would need a
// candidate rebuild).
BENCHMARK(BM_LimitKernelDenseBed)->Iterations(dem::bench::iterations(5))->UseRealTime()->Unit(benchmark::kMillisecond);
BENCHMARK(BM_EngineDenseBed)->Arg(1)->Arg(2)->Iterations(dem::bench::iterations(5))->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();

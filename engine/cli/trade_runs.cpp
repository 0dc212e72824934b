// `dem trade`: one run of a setting, sampled at the comparison times (trade_support.h).
#include <chrono>
#include <cmath>
#include <functional>
#include <stdexcept>

#include "engine/cli/energy_audit.h"
#include "engine/cli/trade_support.h"
#include "engine/hash_mix.h"

namespace dem::cli::trade {
namespace {

/// What the metrics count from: the books at the run's start (zero for a run from the scene's start).
struct Baseline {
  double time = 0, dissipated = 0, wall_work = 0, fines_dissipated = 0, spectra_dissipated = 0;
  std::vector<double> spectrum;
};

/// Every kind's bins, in the order of Sample::spectrum.
std::vector<double> spectrum_bins(const CollisionSpectra& spectra) {
  std::vector<double> bins;
  for (CollisionSpectra::Kind kind = 0; kind < spectra.kind_count(); ++kind)
    for (int q = 0; q < CollisionSpectra::quantity_count; ++q)
      for (int b = 0; b < CollisionSpectra::bin_count; ++b)
        bins.push_back(spectra.energy(kind, static_cast<CollisionSpectra::Quantity>(q), b));
  return bins;
}

Baseline baseline_of(const World& world) {
  Baseline b;
  b.time = world.time();
  b.dissipated = world.dissipated_energy();
  b.wall_work = world.wall_work();
  if (const CollisionSpectra* spectra = world.collision_spectra()) {
    b.spectrum = spectrum_bins(*spectra);
    b.fines_dissipated = spectra->dissipated_by_class(0);
    b.spectra_dissipated = spectra->dissipated_over_kinds();
  }
  return b;
}

Sample sample_of(const World& world, bool trajectory, const Vec3& up, const Baseline& start) {
  Sample s;
  s.time = world.time();
  const State& st = world.state();
  if (trajectory)
    for (const ParticleIndex p : st.index_of_id) {  // in id order
      if (p == removed_slot) continue;
      s.position.push_back(st.position[p]);
      s.velocity.push_back(st.velocity[p]);
    }
  const Energies e = world.energies();
  s.observable[dissipated_energy] = world.dissipated_energy() - start.dissipated;
  s.observable[kinetic_energy] = e.kinetic + e.rotational;
  std::vector<double> height;
  height.reserve(st.size());
  for (std::size_t p = 0; p < st.size(); ++p) height.push_back(st.position[p].dot(up));
  const std::size_t top = std::max<std::size_t>(1, (height.size() + 9) / 10);
  if (!height.empty()) {
    std::nth_element(height.begin(), height.begin() + static_cast<std::ptrdiff_t>(top - 1), height.end(),
                     std::greater<double>());
    double sum = 0;
    std::sort(height.begin(), height.begin() + static_cast<std::ptrdiff_t>(top), std::greater<double>());
    for (std::size_t k = 0; k < top; ++k) sum += height[k];
    s.observable[bed_height] = sum / static_cast<double>(top);
  }
  double force = 0;
  for (const WallLoad& load : world.wall_loads()) force += load.force.norm();
  s.observable[wall_force] = force;
  const double elapsed = s.time - start.time;
  s.observable[power_draw] = elapsed > 0 ? (world.wall_work() - start.wall_work) / elapsed : 0;
  if (const CollisionSpectra* spectra = world.collision_spectra()) {
    // Every kind's bins: with size classes the distance compares the spectra kind by kind.
    s.spectrum = spectrum_bins(*spectra);
    for (std::size_t k = 0; k < start.spectrum.size(); ++k) s.spectrum[k] -= start.spectrum[k];
    if (spectra->class_count() > 1) {
      const double all = spectra->dissipated_over_kinds() - start.spectra_dissipated;
      s.observable[fines_dissipation_share] =
          all != 0 ? (spectra->dissipated_by_class(0) - start.fines_dissipated) / all : 0;
    }
  }
  return s;
}

/// Counter-based draw in [-1, 1] from (seed, particle, component): splitmix64 of a mixed key.
double draw(std::uint64_t seed, std::uint64_t particle, std::uint64_t component) {
  std::uint64_t z = seed * 0x9E3779B97F4A7C15ull ^ (particle + 1) * 0xBF58476D1CE4E5B9ull ^ (component + 7) * 0x94D049BB133111EBull;
  z = splitmix64_mix(z);
  return static_cast<double>(z >> 11) * 0x1.0p-53 * 2 - 1;
}

/// Perturbs initial velocities by 1e-9 relative and positions by 1e-12 m (per component, seeded).
void perturb(WorldConfig& config, std::uint64_t seed) {
  const int dims = config.model.dimension == 2 ? 2 : 3;
  for (std::size_t p = 0; p < config.particles.size(); ++p) {
    ParticleConfig& c = config.particles[p];
    for (int k = 0; k < dims; ++k) {
      c.velocity[k] *= 1 + 1e-9 * draw(seed, p, static_cast<std::uint64_t>(k));
      c.position[k] += 1e-12 * draw(seed, p, static_cast<std::uint64_t>(k + 3));
    }
  }
}

/// The same draws for a world started from a checkpoint, on its velocities only: moving a particle
/// would leave its contacts' springs as they were.
void perturb(World& world, std::uint64_t seed) {
  const int dims = world.config().model.dimension == 2 ? 2 : 3;
  const State& st = world.state();
  std::uint64_t q = 0;  // the particle's place in id order, whatever order the slots are in
  for (const ParticleIndex p : st.index_of_id) {
    if (p == removed_slot) continue;
    Vec3 v = st.velocity[p];
    for (int k = 0; k < dims; ++k) v[k] *= 1 + 1e-9 * draw(seed, q, static_cast<std::uint64_t>(k));
    world.set_velocity(st.id[p], v);
    ++q;
  }
}

}  // namespace

Vec3 up_direction(const WorldConfig& config) {
  const Vec3 g = config.model.gravity;
  if (g.norm() > 0) return -g.normalized();
  return config.model.dimension == 2 ? Vec3(0, 1, 0) : Vec3(0, 0, 1);
}

RunResult run_setting(WorldConfig config, const Plan& plan, std::uint64_t seed) {
  RunResult r;
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  try {
    const bool from_checkpoint = !plan.checkpoint.empty();
    if (seed > 0 && !from_checkpoint) perturb(config, seed);
    World world(config);
    if (from_checkpoint) {
      world.start_from_checkpoint(plan.checkpoint, plan.hashes);
      if (seed > 0) perturb(world, seed);
    }
    const double sync = world.sync_interval();
    const double ratio = plan.interval / sync;
    const auto per_sample = static_cast<std::int64_t>(std::llround(ratio));
    if (per_sample < 1 || std::abs(ratio - static_cast<double>(per_sample)) > 1e-6 * ratio)
      throw std::runtime_error("the sync interval " + std::to_string(sync) + " s does not divide the comparison interval");
    EnergyAudit audit(world);
    const Baseline baseline = baseline_of(world);
    r.samples.push_back(sample_of(world, plan.metrics.trajectory, plan.up, baseline));
    for (std::int64_t k = 1; k <= plan.count && r.status == "ok"; ++k) {
      for (std::int64_t i = 0; i < per_sample; ++i)
        if (world.advance_sync_interval() != StepStatus::ok) {
          r.status = "diverged";
          r.why = "non-finite positions or velocities at t = " + std::to_string(world.time()) + " s";
          break;
        }
      if (r.status != "ok") break;
      if (std::string why = audit.check(world); !why.empty()) {
        r.status = "diverged";
        r.why = why;
        break;
      }
      audit.accept(world);
      r.samples.push_back(sample_of(world, plan.metrics.trajectory, plan.up, baseline));
    }
    r.counters = world.counters();
  } catch (const std::exception& e) {
    r.status = "failed";
    r.why = e.what();
  }
  r.wall_time = elapsed();
  return r;
}

}  // namespace dem::cli::trade

// `dem trade`: one run of a setting, sampled at the comparison times (trade_support.h).
#include <chrono>
#include <cmath>
#include <functional>
#include <stdexcept>

#include "engine/cli/energy_audit.h"
#include "engine/cli/trade_support.h"

namespace dem::cli::trade {
namespace {

Sample sample_of(const World& world, bool trajectory, const Vec3& up) {
  Sample s;
  s.time = world.time();
  const State& st = world.state();
  if (trajectory)
    for (std::size_t p = 0; p < st.size(); ++p) {  // slots are in id order
      s.position.push_back(st.position[p]);
      s.velocity.push_back(st.velocity[p]);
    }
  const Energies e = world.energies();
  s.observable[dissipated_energy] = world.dissipated_energy();
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
  s.observable[power_draw] = s.time > 0 ? world.wall_work() / s.time : 0;
  if (const CollisionSpectra* spectra = world.collision_spectra())
  {
    // Every kind's bins: with size classes the distance compares the spectra kind by kind.
    for (CollisionSpectra::Kind kind = 0; kind < spectra->kind_count(); ++kind)
      for (int q = 0; q < CollisionSpectra::quantity_count; ++q)
        for (int b = 0; b < CollisionSpectra::bin_count; ++b)
          s.spectrum.push_back(spectra->energy(kind, static_cast<CollisionSpectra::Quantity>(q), b));
    if (spectra->class_count() > 1) s.observable[fines_dissipation_share] = spectra->dissipation_share(0);
  }
  return s;
}

/// Counter-based draw in [-1, 1] from (seed, particle, component): splitmix64 of a mixed key.
double draw(std::uint64_t seed, std::uint64_t particle, std::uint64_t component) {
  std::uint64_t z = seed * 0x9E3779B97F4A7C15ull ^ (particle + 1) * 0xBF58476D1CE4E5B9ull ^ (component + 7) * 0x94D049BB133111EBull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * 0x1.0p-53 * 2 - 1;
}

}  // namespace

Vec3 up_direction(const WorldConfig& config) {
  const Vec3 g = config.model.gravity;
  if (g.norm() > 0) return -g.normalized();
  return config.model.dimension == 2 ? Vec3(0, 1, 0) : Vec3(0, 0, 1);
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

/// Runs `config` to K T, sampling at every k T. Never throws for a failing run: the status says it.
RunResult run_setting(WorldConfig config, const Plan& plan) {
  RunResult r;
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  try {
    World world(config);
    const double sync = world.sync_interval();
    const double ratio = plan.interval / sync;
    const auto per_sample = static_cast<std::int64_t>(std::llround(ratio));
    if (per_sample < 1 || std::abs(ratio - static_cast<double>(per_sample)) > 1e-6 * ratio)
      throw std::runtime_error("the sync interval " + std::to_string(sync) + " s does not divide the comparison interval");
    EnergyAudit audit(world);
    r.samples.push_back(sample_of(world, plan.metrics.trajectory, plan.up));
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
      r.samples.push_back(sample_of(world, plan.metrics.trajectory, plan.up));
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

// `dem check`: loads and validates a scene without running it, then prints what it holds and, for
// every contact class, the stability and contact figures of PHYSICS.md 1.2 and 2, using the lightest
// particles of each material (the worst case for the step).
#include <cmath>
#include <cstdio>
#include <limits>

#include "engine/cli/commands.h"
#include "engine/damping.h"
#include "engine/materials.h"
#include "engine/walls.h"

namespace dem::cli {
namespace {

const char* separation_name(Separation s) { return s == Separation::force_zero ? "force_zero" : "overlap"; }

struct Lightest {
  Real mass = std::numeric_limits<Real>::infinity();
  Real radius = 0;
};

}  // namespace

int check_command(const std::string& path, const std::vector<std::string>& overrides) {
  const Scene scene = load_scene(path, overrides);
  const WorldConfig& w = scene.world;
  const MaterialTable materials(w.materials, w.contacts, w.model.separation);
  const Real kappa = inertia_factor(w.model.dimension);

  std::vector<Lightest> lightest(materials.material_count());
  for (const ParticleConfig& p : w.particles) {
    const int m = materials.find(p.material);
    const Real mass = particle_mass(p, materials.density(static_cast<std::uint16_t>(m)), w.model.dimension,
                                    w.model.thickness);
    if (mass < lightest[m].mass) lightest[m] = {mass, p.radius};
  }

  std::printf("scene %s (%s)\n", scene.name.c_str(), scene.file.c_str());
  std::printf("  particles: %zu, dimension %d, walls: %zu\n", w.particles.size(), w.model.dimension, w.walls.size());
  for (std::size_t m = 0; m < materials.material_count(); ++m)
    std::printf("  material %s: density %g kg/m^3\n", materials.name(static_cast<std::uint16_t>(m)).c_str(),
                materials.density(static_cast<std::uint16_t>(m)));
  std::printf("  physics: normal spring-dashpot (separation %s)%s%s%s%s\n", separation_name(w.model.separation),
              w.model.gravity.norm() > 0 ? ", gravity" : "", materials.any_friction() ? ", friction" : "",
              materials.any_rolling() ? (w.model.rolling_mode == RollingMode::seed ? ", rolling resistance (seed mode)"
                                                                                 : ", rolling resistance (standard mode)")
                                      : "",
              w.walls.empty() ? "" : ", walls");
  const bool exact = w.integrator.method == Method::exact;
  const IntegratorConfig& ic = w.integrator;
  const bool doubling = ic.control == Control::doubling;
  const Real dt_base = ic.dt_base > 0 ? ic.dt_base : ic.dt;
  // The step the stability check applies to: the only step (fixed), or the finest one (doubling).
  const Real checked_step = doubling ? std::ldexp(dt_base, ic.level_min) : ic.dt;
  if (doubling) {
    std::printf("  integrator: %s, step doubling with tolerance %g, until %g s\n", exact ? "exact" : "verlet",
                ic.tolerance, scene.run.until);
    std::printf("    levels %d .. %d: steps from %.4g s to %.4g s (dt_base %g s), sync interval %.4g s\n",
                ic.level_min, ic.level_max, checked_step, std::ldexp(dt_base, ic.level_max), dt_base,
                std::ldexp(dt_base, ic.level_max));
  } else {
    std::printf("  integrator: %s, fixed dt = %g s, until %g s\n", exact ? "exact" : "verlet", ic.dt,
                scene.run.until);
  }

  bool unstable = false;
  auto report = [&](const std::string& label, std::uint16_t pair, const EffectiveMasses& em) {
    const LawConstants c = materials.constants(pair, em);
    const Real omega0 = std::sqrt(c.k_n / em.m_star);
    const Real zeta = c.c_n / (2 * std::sqrt(c.k_n * em.m_star));
    const Real cundall = 2 * std::sqrt(em.m_star / c.k_n);
    const Real damped_limit = 2 * (std::sqrt(1 + zeta * zeta) - zeta) / omega0;
    Real limit = damped_limit;
    if (materials.any_friction() && c.k_t > 0) limit = std::min(limit, 2 / std::sqrt(c.k_t / em.m_t));
    const Real tsuji = pi * std::sqrt(em.m_star / c.k_n) / 5;
    std::printf("  contact %s: m* = %.4g kg, k = %.4g N/m, zeta = %.4g\n", label.c_str(), em.m_star, c.k_n, zeta);
    std::printf("    Cundall-Strack limit 2 sqrt(m*/k) = %.4g s (with damping and tangential spring: %.4g s), "
                "Tsuji step = %.4g s\n", cundall, limit, tsuji);
    for (Separation s : {Separation::force_zero, Separation::overlap})
      std::printf("    %-10s: contact time %.4g s, restitution %.5g\n", separation_name(s),
                  dimensionless_contact_time(zeta, s) / omega0, restitution_from_damping_ratio(zeta, s));
    // The exact stepper has no stability limit for one contact (PHYSICS.md 2); Verlet has.
    if (!exact && checked_step > limit) {
      unstable = true;
      if (doubling)
        std::printf("    WARNING: the finest step %g s (level_min %d) exceeds the stability limit %.4g s of this "
                    "contact: lower integrator.level_min\n", checked_step, ic.level_min, limit);
      else
        std::printf("    WARNING: dt = %g s exceeds the stability limit %.4g s of this contact\n", ic.dt, limit);
    }
  };
  const std::size_t n = materials.material_count();
  for (std::size_t a = 0; a < n; ++a) {
    if (!std::isfinite(lightest[a].mass)) continue;
    const Real inv_ma = 1 / lightest[a].mass, inv_ia = inv_ma / (kappa * lightest[a].radius * lightest[a].radius);
    for (std::size_t b = a; b < n; ++b) {
      if (!std::isfinite(lightest[b].mass)) continue;
      const Real inv_mb = 1 / lightest[b].mass, inv_ib = inv_mb / (kappa * lightest[b].radius * lightest[b].radius);
      const auto ua = static_cast<std::uint16_t>(a), ub = static_cast<std::uint16_t>(b);
      report(materials.name(ua) + "-" + materials.name(ub), materials.pair_class(ua, ub),
             effective_masses(inv_ma, inv_ia, lightest[a].radius, inv_mb, inv_ib, lightest[b].radius));
    }
    for (const WallConfig& wall : w.walls) {
      const auto ua = static_cast<std::uint16_t>(a);
      const auto uw = static_cast<std::uint16_t>(materials.find(wall.material));
      report(materials.name(ua) + "-wall '" + wall.name + "'", materials.pair_class(ua, uw),
             effective_masses(inv_ma, inv_ia, lightest[a].radius, 0, 0, std::numeric_limits<Real>::infinity()));
    }
  }
  std::printf("%s\n", unstable ? "check: valid, with warnings" : "check: valid");
  return 0;
}

}  // namespace dem::cli

#include "engine/cli/stability.h"

#include <cmath>
#include <cstdio>
#include <limits>

#include "engine/materials.h"
#include "engine/walls.h"

namespace dem::cli {
namespace {

struct Lightest {
  Real mass = std::numeric_limits<Real>::infinity();
  Real radius = 0;
  std::size_t count = 0;  // particles of the material
};

std::string format(const char* pattern, Real a, Real b) {
  char text[512];
  std::snprintf(text, sizeof text, pattern, a, b);
  return text;
}

}  // namespace

std::vector<ContactStability> contact_stability(const WorldConfig& w) {
  const MaterialTable materials(w.materials, w.contacts, w.model.separation);
  const Real kappa = inertia_factor(w.model.dimension);
  std::vector<Lightest> lightest(materials.material_count());
  for (const ParticleConfig& p : w.particles) {
    const int m = materials.find(p.material);
    const Real mass = particle_mass(p, materials.density(static_cast<std::uint16_t>(m)), w.model.dimension,
                                    w.model.thickness);
    if (mass < lightest[m].mass) lightest[m].mass = mass, lightest[m].radius = p.radius;
    ++lightest[m].count;
  }
  std::vector<ContactStability> classes;
  auto add = [&](const std::string& label, std::uint16_t pair, const EffectiveMasses& em) {
    const LawConstants c = materials.constants(pair, em);
    ContactStability s;
    s.label = label;
    s.m_star = em.m_star;
    s.k_n = c.k_n;
    s.omega0 = std::sqrt(c.k_n / em.m_star);
    s.zeta = c.c_n / (2 * std::sqrt(c.k_n * em.m_star));
    s.cundall = 2 * std::sqrt(em.m_star / c.k_n);
    // A predicted dashpot (integrator.predicted_dashpot) acts on the step like one of twice the ratio.
    const Real z = w.integrator.predicted_dashpot ? 2 * s.zeta : s.zeta;
    s.limit = 2 * (std::sqrt(1 + z * z) - z) / s.omega0;
    if (materials.any_friction() && c.k_t > 0) s.limit = std::min(s.limit, 2 / std::sqrt(c.k_t / em.m_t));
    s.tsuji = pi * std::sqrt(em.m_star / c.k_n) / 5;
    classes.push_back(s);
  };
  const std::size_t n = materials.material_count();
  for (std::size_t a = 0; a < n; ++a) {
    if (!std::isfinite(lightest[a].mass)) continue;
    const Real inv_ma = 1 / lightest[a].mass, inv_ia = inv_ma / (kappa * lightest[a].radius * lightest[a].radius);
    for (std::size_t b = a; b < n; ++b) {
      if (!std::isfinite(lightest[b].mass) || (a == b && lightest[a].count < 2)) continue;  // no such pair
      const Real inv_mb = 1 / lightest[b].mass, inv_ib = inv_mb / (kappa * lightest[b].radius * lightest[b].radius);
      const auto ua = static_cast<std::uint16_t>(a), ub = static_cast<std::uint16_t>(b);
      add(materials.name(ua) + "-" + materials.name(ub), materials.pair_class(ua, ub),
          effective_masses(inv_ma, inv_ia, lightest[a].radius, inv_mb, inv_ib, lightest[b].radius));
    }
    for (const WallConfig& wall : w.walls) {
      const auto ua = static_cast<std::uint16_t>(a);
      const auto uw = static_cast<std::uint16_t>(materials.find(wall.material));
      add(materials.name(ua) + "-wall '" + wall.name + "'", materials.pair_class(ua, uw),
          effective_masses(inv_ma, inv_ia, lightest[a].radius, 0, 0, std::numeric_limits<Real>::infinity()));
    }
  }
  return classes;
}

Real checked_step(const IntegratorConfig& ic) {
  const Real dt_base = ic.dt_base > 0 ? ic.dt_base : ic.dt;
  return ic.control == Control::doubling ? std::ldexp(dt_base, ic.level_min) : ic.dt;
}

std::vector<std::string> stability_warnings(const WorldConfig& w, const std::vector<ContactStability>& classes) {
  std::vector<std::string> warnings;
  if (w.integrator.method == Method::exact) return warnings;
  const Real step = checked_step(w.integrator);
  for (const ContactStability& s : classes) {
    if (step <= s.limit) continue;
    if (w.integrator.control == Control::doubling)
      warnings.push_back(format("the finest step %g s exceeds the stability limit %.4g s of contact ", step, s.limit) +
                         s.label + ": lower integrator.level_min");
    else
      warnings.push_back(format("dt = %g s exceeds the stability limit %.4g s of contact ", step, s.limit) + s.label +
                         " (docs/physics.md 4.2): lower integrator.dt, or use integrator.control = \"doubling\" or "
                         "integrator.method = \"exact\"");
  }
  return warnings;
}

}  // namespace dem::cli

// `dem check`: loads and validates a scene without running it, then prints what it holds and, for
// every contact class, the stability and contact figures of docs/physics.md 2.2 and 4.2, using the lightest
// particles of each material (the worst case for the step).
#include <cmath>
#include <cstdio>

#include "engine/cli/commands.h"
#include "engine/cli/stability.h"
#include "engine/damping.h"
#include "engine/materials.h"

namespace dem::cli {
namespace {

const char* separation_name(Separation s) { return s == Separation::force_zero ? "force_zero" : "overlap"; }

}  // namespace

int check_command(const std::string& path, const std::vector<std::string>& overrides) {
  const Scene scene = load_scene(path, overrides);
  const WorldConfig& w = scene.world;
  const MaterialTable materials(w.materials, w.contacts, w.model.separation);

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
  if (doubling) {
    std::printf("  integrator: %s, step doubling with tolerance %g, until %g s\n", exact ? "exact" : "verlet",
                ic.tolerance, scene.run.until);
    std::printf("    levels %d .. %d: steps from %.4g s to %.4g s (dt_base %g s), sync interval %.4g s\n",
                ic.level_min, ic.level_max, checked_step(ic), std::ldexp(dt_base, ic.level_max), dt_base,
                std::ldexp(dt_base, ic.level_max));
    std::printf("    %s\n", ic.particle_levels ? "a level per particle inside each touching group (particle_levels)"
                                                 : exact ? "one level per touching group (the exact stepper's pair flows "
                                                           "need both sides live)"
                                                         : "one level per touching group, its finest member's "
                                                           "(particle_levels = false)");
  } else {
    std::printf("  integrator: %s, fixed dt = %g s, until %g s\n", exact ? "exact" : "verlet", ic.dt,
                scene.run.until);
  }

  // The exact stepper has no stability limit for one contact (docs/physics.md 4.2); Verlet has.
  const std::vector<ContactStability> classes = contact_stability(w);
  for (const ContactStability& s : classes) {
    std::printf("  contact %s: m* = %.4g kg, k = %.4g N/m, zeta = %.4g\n", s.label.c_str(), s.m_star, s.k_n, s.zeta);
    std::printf("    Cundall-Strack limit 2 sqrt(m*/k) = %.4g s (with damping and tangential spring: %.4g s), "
                "Tsuji step = %.4g s\n", s.cundall, s.limit, s.tsuji);
    for (Separation sep : {Separation::force_zero, Separation::overlap})
      std::printf("    %-10s: contact time %.4g s, restitution %.5g\n", separation_name(sep),
                  dimensionless_contact_time(s.zeta, sep) / s.omega0, restitution_from_damping_ratio(s.zeta, sep));
  }
  const std::vector<std::string> warnings = stability_warnings(w, classes);
  for (const std::string& warning : warnings) std::printf("  WARNING: %s\n", warning.c_str());
  std::printf("%s\n", warnings.empty() ? "check: valid" : "check: valid, with warnings");
  return 0;
}

}  // namespace dem::cli

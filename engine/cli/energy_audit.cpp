#include "engine/cli/energy_audit.h"

#include <cmath>
#include <cstdio>

namespace dem::cli {

std::string EnergyAudit::check(const World& world) const {
  char text[600];
  const Energies now = world.energies();
  const EnergyBalance whole = world.energy_balance();
  const Real dissipated = world.dissipated_energy(), wall_work = world.wall_work();
  const Energies& e = good_.energies;
  // In play in the window: what moved or was stored at its start, the potential energy released
  // or taken up, and what the contacts dissipated and the walls did in it.
  const Real in_play = e.kinetic + e.rotational + e.elastic + std::abs(now.potential - e.potential) +
                       std::abs(dissipated - good_.dissipated) + std::abs(wall_work - good_.wall_work);
  // Round-off floor: the balance holds potential energies measured from the origin and running
  // totals that only grow; two balances differ by ~1e-16 of those sizes even with nothing in play.
  const Real floor = 1e-12 * (std::abs(e.potential) + std::abs(now.potential) + std::abs(dissipated) + std::abs(wall_work));
  const Real growth = whole.error - good_.error;
  // Written as !(a <= b) so that a NaN fails.
  if (!(growth <= energy_growth_limit * (in_play + floor))) {
    const World::Culprit c = world.fastest_particle();
    std::snprintf(text, sizeof text,
                  "the energy grew by %.3g J since t = %.9g s beyond the work put in (%.0f%% of the %.3g J in play "
                  "since then; fastest particle %u at %.3g m/s)",
                  growth, good_.time, 100 * growth / (in_play + floor), in_play + floor, c.particle, c.value);
    return text;
  }
  if (!(whole.error <= energy_growth_limit * whole.scale)) {
    const World::Culprit c = world.fastest_particle();
    std::snprintf(text, sizeof text,
                  "the energy grew by %.3g J since the start beyond the work put in (%.0f%% of the %.3g J in play; "
                  "fastest particle %u at %.3g m/s)",
                  whole.error, 100 * whole.error / whole.scale, whole.scale, c.particle, c.value);
    return text;
  }
  // The deepest overlap of any step since the start, not only now: an impact too fast for the
  // stiffness can go deep and pass through between two audits.
  const World::Culprit& o = world.deepest_overlap_seen();
  if (o.value > overlap_limit) {
    if (o.particle == o.partner)
      std::snprintf(text, sizeof text,
                    "particle %u overlapped a wall by %.0f%% of its radius at t = %.9g s (limit %.0f%%; an impact "
                    "this deep is outside the linear contact law: raise the contact's normal_stiffness or lower the "
                    "impact speed)",
                    o.particle, 100 * o.value, o.time, 100 * overlap_limit);
    else
      std::snprintf(text, sizeof text,
                    "particles %u and %u overlapped by %.0f%% of the smaller radius at t = %.9g s (limit %.0f%%; an "
                    "impact this deep is outside the linear contact law: raise the contact's normal_stiffness or lower "
                    "the impact speed)",
                    o.particle, o.partner, 100 * o.value, o.time, 100 * overlap_limit);
    return text;
  }
  return "";
}

std::string step_travel_warning(const World& world) {
  const World::Culprit& t = world.longest_step_travel_seen();
  if (!(t.value > step_travel_limit)) return "";
  char text[600];
  std::snprintf(text, sizeof text,
                "particle %u moves %.3g of its radii per step at t = %.9g s: a step that long can carry it through a "
                "wall or another particle without a contact being seen. Reduce integrator.dt below %.3g s, or use "
                "integrator.control = \"doubling\" or integrator.method = \"exact\", which find contacts on the path",
                t.particle, t.value, t.time, world.config().integrator.dt * step_travel_limit / t.value);
  return text;
}

void EnergyAudit::accept(const World& world) {
  good_ = {world.time(), world.energy_balance().error, world.energies(), world.dissipated_energy(), world.wall_work()};
}

}  // namespace dem::cli

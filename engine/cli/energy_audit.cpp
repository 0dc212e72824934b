#include "engine/cli/energy_audit.h"

#include <cmath>
#include <cstdio>

namespace dem::cli {

std::string EnergyAudit::check(const World& world) const {
  char text[400];
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
  const World::Culprit o = world.deepest_overlap();
  if (o.value > overlap_limit) {
    std::snprintf(text, sizeof text, "particles %u and %u overlap by %.0f%% of the smaller radius (limit %.0f%%)",
                  o.particle, o.partner, 100 * o.value, 100 * overlap_limit);
    return text;
  }
  return "";
}

void EnergyAudit::accept(const World& world) {
  good_ = {world.time(), world.energy_balance().error, world.energies(), world.dissipated_energy(), world.wall_work()};
}

}  // namespace dem::cli

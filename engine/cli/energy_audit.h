#pragma once
// The divergence audit of `dem run` and `dem trade`: a state is sound when energy has not appeared
// from nowhere and no overlap, at any step since the start, is beyond what the linear contact law
// describes.
//
// Energy is audited per window, from the last good state to now: the balance error of
// World::energy_balance() may not grow by more than a fraction of the energy in play in that window.
// The whole-run balance alone is not enough: its scale holds everything dissipated and all wall work
// since the start, so late in a long run a real blow-up hides under it. The whole-run check stays
// beside the window's, for growth spread thinly over many short windows.
#include <string>

#include "engine/world.h"

namespace dem::cli {

/// Energy appearing from nowhere beyond this fraction of the energy in play stops a run as diverged:
/// sound runs stay orders of magnitude below (Verlet's error is ~(omega h)^2), unstable ones far above.
inline constexpr Real energy_growth_limit = 0.5;
/// An overlap beyond this fraction of the smaller radius is not a contact the linear law describes.
inline constexpr Real overlap_limit = 0.5;
/// A fixed Verlet step carrying a particle further than its radius can step over a contact.
inline constexpr Real step_travel_limit = 1.0;

/// Empty, or a warning naming the particle whose steps have been longer than step_travel_limit of
/// its radius, when, and the settings to change (World::longest_step_travel_seen). A warning, not a
/// stop: a particle flying far from everything may take long steps safely.
std::string step_travel_warning(const World& world);

class EnergyAudit {
 public:
  /// The state a run starts from (scene or checkpoint) is good by definition.
  explicit EnergyAudit(const World& world) { accept(world); }

  /// Empty if the state is sound, else why the run must stop.
  std::string check(const World& world) const;
  /// The state passed the audit: it is the last good one, and the next window starts here.
  void accept(const World& world);
  Real last_good_time() const { return good_.time; }

 private:
  struct Mark {
    Real time;          // [s]
    Real error;         // balance error since the start [J]
    Energies energies;  // [J]
    Real dissipated;    // since the start [J]
    Real wall_work;     // since the start [J]
  };
  Mark good_{};
};

}  // namespace dem::cli

#pragma once
// Stability figures of every contact class a scene can form (docs/physics.md 2.2 and 4.2), from the lightest
// particle of each material (the worst case for the step): shared by `dem check`, which prints them,
// and `dem run`, which warns at load when velocity Verlet's step exceeds a limit.
#include <string>
#include <vector>

#include "engine/scene.h"

namespace dem::cli {

struct ContactStability {
  std::string label;   // "a-b" for two materials, "a-wall 'name'" for a wall
  Real m_star = 0;     // [kg]
  Real k_n = 0;        // [N/m]
  Real zeta = 0;       // damping ratio [-]
  Real omega0 = 0;     // [1/s]
  Real cundall = 0;    // 2 sqrt(m*/k) [s]
  Real limit = 0;      // Verlet's limit with damping and, under friction, the tangential spring [s]
  Real tsuji = 0;      // pi sqrt(m*/k) / 5 [s]
};

std::vector<ContactStability> contact_stability(const WorldConfig& world);

/// The step Verlet's stability applies to: the only step (fixed control) or the finest (doubling).
Real checked_step(const IntegratorConfig& integrator);

/// One warning line per contact class whose limit the checked step exceeds (empty for the exact
/// stepper, which has no stability limit for a single contact), naming the setting to change.
std::vector<std::string> stability_warnings(const WorldConfig& world, const std::vector<ContactStability>& classes);

}  // namespace dem::cli

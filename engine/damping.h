#pragma once
// Restitution, damping ratio and contact duration of the linear spring-dashpot for an isolated pair
// without body force, in both separation conventions (docs/physics.md 2.2). Used to convert scene input,
// by `dem check`, and as test oracles.
#include "engine/config.h"

namespace dem {

/// Coefficient of restitution for damping ratio zeta >= 0 under `separation`.
/// Overlap convention: 0 for zeta >= 1 (no rebound in finite time).
Real restitution_from_damping_ratio(Real zeta, Separation separation);

/// Damping ratio giving restitution e in (0, 1] under `separation` (inverse of the above).
Real damping_ratio_from_restitution(Real e, Separation separation);

/// Contact duration times omega0 (dimensionless) for damping ratio zeta; infinity where the
/// overlap convention never separates (zeta >= 1).
Real dimensionless_contact_time(Real zeta, Separation separation);

}  // namespace dem

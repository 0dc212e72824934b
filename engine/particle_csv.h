#pragma once
// Particles from CSV files with a header row. Required columns: x, y, z, radius; optional: id
// (ignored, rows keep file order), vx, vy, vz, wx, wy, wz, density, mass. Units SI.
// Errors (missing file, missing column, a bad number) throw InputError naming file, line and column.
#include <string>
#include <vector>

#include "engine/config.h"

namespace dem {

std::vector<ParticleConfig> read_particle_csv(const std::string& path, const std::string& material = "default");

/// Writes particles in the same format (id, x, y, z, vx, vy, vz, wx, wy, wz, radius, density),
/// to a temporary file renamed into place.
void write_particle_csv(const std::string& path, const std::vector<ParticleConfig>& particles);

}  // namespace dem

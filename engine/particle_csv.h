#pragma once
// Particles from and to CSV files with a header row, in any column order. Units SI.
//   required: x, y, z [m], radius [m]
//   optional: id (a whole number from 0 to 4294967294, each at most once: the particle's stable id,
//             as in snapshots and every output), vx, vy, vz [m/s], wx, wy, wz [rad/s],
//             density [kg/m^3], mass [kg] (per row one of them or neither, the material's density
//             then; an empty cell is "not given"), material (a name the scene defines)
// Errors (missing file, unknown, repeated or missing column, a bad number or id, a repeated id)
// throw InputError naming file, line, column and what would be valid.
#include <string>
#include <vector>

#include "engine/config.h"

namespace dem {

/// Where each particle of a file was: its line, and the columns (1-based, 0 when absent) of the
/// cells the scene loader checks against the rest of the scene.
struct ParticleCsvLayout {
  std::vector<int> lines;  // one per particle
  int id_column = 0;
  int material_column = 0;
};

/// Reads a particle file; `material` is every row's material unless the file has a material column.
/// Rows keep file order; a row with an id gets it (ParticleConfig::id).
std::vector<ParticleConfig> read_particle_csv(const std::string& path, const std::string& material = "default",
                                              ParticleCsvLayout* layout = nullptr);

/// Whether a material name fits a CSV cell as it stands: not empty, no comma, quote or line break,
/// and no space or tab at either end (the reader trims those).
bool fits_csv_cell(const std::string& name);

/// The header write_particle_csv writes.
inline constexpr const char* particle_csv_header = "id,x,y,z,vx,vy,vz,wx,wy,wz,radius,density,mass,material";

/// Writes particles with every column of particle_csv_header, numbers with 17 significant digits
/// (read back they are the same doubles, so writing what was read gives the same bytes): id (a
/// particle without one gets the next after the largest so far, as a World gives it), state,
/// radius, the mass or the density it was given (the other cell empty; both empty when it has
/// neither) and material. Written to a temporary file renamed into place. Throws
/// std::invalid_argument for ids that do not increase or a material name a CSV cell cannot hold.
void write_particle_csv(const std::string& path, const std::vector<ParticleConfig>& particles);

}  // namespace dem

#pragma once
// What `dem run` records of a World at a sync time: the rows of series.csv, walls.csv and
// trajectories.csv, the VTK snapshot of the particles and walls, the energy block of summary.json
// and the state hash as text. Reads the World only.
#include <cstdint>
#include <string>
#include <vector>

#include "engine/csv_writer.h"
#include "engine/json_writer.h"
#include "engine/wall_geometry.h"
#include "engine/world.h"

namespace dem::cli {

/// A row of series.csv (csv_writer.h, series_columns).
std::vector<double> series_row(const World& world);
/// One row of trajectories.csv per particle, in id order.
void append_trajectories(SeriesWriter& out, const World& world);
/// A row of walls.csv: each wall's force and torque.
std::vector<double> wall_row(const World& world);
/// Display geometry of the walls at the world's current time; infinite things get a finite extent.
WallGeometry wall_geometry(const World& world);
/// The energies, wall work and momentum (summary.json's "start" and "end").
JsonObject energy_json(const World& world);
/// 16 hexadecimal digits (state hashes).
std::string hex(std::uint64_t v);

}  // namespace dem::cli

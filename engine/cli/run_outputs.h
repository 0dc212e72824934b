#pragma once
// The files `dem run` writes as it goes (docs/design.md, Outputs): series.csv, walls.csv,
// trajectories.csv, VTK snapshots (particles, walls and on request the contact network) with their
// .pvd indexes, and a mill's files; and when each is due.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <optional>

#include "engine/cli/mill_outputs.h"
#include "engine/csv_writer.h"
#include "engine/vtk_writer.h"
#include "engine/scene.h"
#include "engine/world.h"

namespace dem::cli {

/// When an output is due: at the first sync time at or after each multiple k * interval. Sync times
/// are products of integers and dt, so k * interval itself may round a hair above the sync time
/// meant to hit it (0.1 * 3 > 0.3): a tolerance of 1e-9 interval absorbs that.
class OutputSchedule {
 public:
  explicit OutputSchedule(Real interval) : interval_(interval) {}
  bool enabled() const { return interval_ > 0; }
  bool due(Real t) const { return enabled() && t >= (static_cast<Real>(next_) - tolerance) * interval_; }
  /// Marks the output at time t done: the next is the first multiple after t.
  void done_at(Real t) { next_ = std::max(next_ + 1, static_cast<std::int64_t>(std::floor(t / interval_ + tolerance)) + 1); }

 private:
  static constexpr Real tolerance = 1e-9;
  Real interval_;
  std::int64_t next_ = 0;
};

/// The output files of one run in folder `out`, with their schedules.
class RunOutputs {
 public:
  /// A new run starts its append-only files afresh; a resumed one (`resuming`: the world holds the
  /// checkpoint's state) keeps what was written up to the checkpoint's time and drops anything later
  /// (written after the checkpoint by the run that died).
  RunOutputs(const Scene& scene, const World& world, const std::filesystem::path& out, bool resuming, bool quiet);

  /// Whether a row or a snapshot is due at sync time t.
  bool due(Real t) const { return rows_.due(t) || snapshots_.due(t); }
  /// Writes what is due at the world's current sync time (everything when `final_row`).
  void write(const World& world, bool final_row);
  /// The mill's outputs, for a scene with a [mill] section; else null.
  MillOutputs* mill() { return mill_ ? &*mill_ : nullptr; }

 private:
  std::filesystem::path out_;
  SeriesWriter series_;
  std::optional<SeriesWriter> trajectories_;
  SeriesWriter walls_;
  PvdIndex particles_pvd_;
  PvdIndex walls_pvd_;
  std::optional<PvdIndex> contacts_pvd_;  // output.contacts
  VtkFormat vtk_format_;
  OutputSchedule rows_;
  OutputSchedule snapshots_;
  std::int64_t snapshot_count_ = 0;  // snapshots in particles.pvd
  std::optional<MillOutputs> mill_;
};

}  // namespace dem::cli

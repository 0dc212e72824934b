#pragma once
// What `dem run` writes for a scene with a [mill] section: mill.csv (a row per output row),
// mill_revolutions.csv (a row per completed revolution, also printed), and the summary's "mill" block
// with mean_power_draw over the steady revolutions.
#include <filesystem>
#include <optional>

#include "engine/mill_monitor.h"
#include "engine/csv_writer.h"
#include "engine/json_writer.h"

namespace dem::cli {

class MillOutputs {
 public:
  /// A resumed run keeps the rows written up to the checkpoint's time (the world's time now).
  MillOutputs(const MillConfig& config, const World& world, const std::filesystem::path& out, bool resuming, bool quiet);

  /// At every sync time: closes completed revolutions.
  void on_sync(const World& world);
  /// At every series row.
  void on_row(const World& world);
  /// The summary's "mill" block (speeds, revolutions, means, drive work and the energy audit).
  JsonObject summary(const World& world) const;
  /// At the end: spectra.csv of the collision energy spectra and, with Python's matplotlib, spectra.png.
  void write_spectra(const World& world) const;
  std::optional<Real> mean_power_draw() const { return monitor_.mean_power_draw(); }

 private:
  MillConfig config_;
  std::filesystem::path out_;
  MillMonitor monitor_;
  SeriesWriter rows_;
  SeriesWriter revolutions_;
  bool quiet_;
};

}  // namespace dem::cli

#include "engine/cli/mill_outputs.h"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "engine/cli/plot_script.h"

namespace dem::cli {

namespace {

std::filesystem::path fresh(const std::filesystem::path& path, bool resuming) {
  if (!resuming) std::filesystem::remove(path);
  return path;
}

/// The numeric rows of a CSV this class wrote (header skipped; nan and inf as strtod reads them).
std::vector<std::vector<double>> read_rows(const std::filesystem::path& path) {
  std::vector<std::vector<double>> rows;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    std::vector<double> row;
    std::stringstream fields(line);
    for (std::string field; std::getline(fields, field, ',');) row.push_back(std::strtod(field.c_str(), nullptr));
    rows.push_back(row);
  }
  return rows;
}

}  // namespace

MillOutputs::MillOutputs(const MillConfig& config, const World& world, const std::filesystem::path& out, bool resuming,
                         bool quiet)
    : config_(config),
      out_(out),
      monitor_(config, world),
      rows_(fresh(out / "mill.csv", resuming),
            {"time", "revolution", "torque", "power_draw", "toe_angle", "shoulder_angle", "drive_work"}),
      revolutions_(fresh(out / "mill_revolutions.csv", resuming),
                   {"end_time", "revolution", "start_time", "torque", "power_draw", "steady", "drive_work"}),
      quiet_(quiet) {
  if (resuming) {
    rows_.truncate_after(world.time());
    revolutions_.truncate_after(world.time());
    // Continue the means from what the run wrote before its checkpoint.
    std::vector<MillRevolution> done;
    for (const std::vector<double>& f : read_rows(revolutions_.path())) {
      if (f.size() < 7) continue;  // not a row of this format
      MillRevolution r;
      r.end = f[0], r.index = static_cast<int>(f[1]), r.start = f[2], r.torque = f[3], r.power_draw = f[4];
      r.steady = f[5] != 0, r.drive_work = f[6];
      done.push_back(r);
    }
    std::optional<MillRow> last_row;
    if (const auto rows = read_rows(rows_.path()); !rows.empty() && rows.back().size() >= 7) {
      last_row.emplace();
      last_row->time = rows.back()[0];
      last_row->drive_work = rows.back()[6];
    }
    monitor_.resume(done, last_row);
  }
}

void MillOutputs::on_sync(const World& world) {
  for (const MillRevolution& r : monitor_.observe(world)) {
    revolutions_.append(
        {r.end, static_cast<double>(r.index), r.start, r.torque, r.power_draw, r.steady ? 1.0 : 0.0, r.drive_work});
    if (!quiet_)
      std::printf("revolution %d: t = %.4g to %.4g s, torque %.6g N m, power draw %.6g W%s\n", r.index, r.start, r.end,
                  r.torque, r.power_draw, r.steady ? "" : " (start-up, not averaged)");
  }
}

void MillOutputs::on_row(const World& world) {
  const MillRow r = monitor_.row(world);
  rows_.append({r.time, r.revolution, r.torque, r.power_draw, r.toe_angle, r.shoulder_angle, r.drive_work});
}

JsonObject MillOutputs::summary(const World& world) const {
  JsonObject j;
  const Real rpm = 60 / (2 * pi);
  j.add("speed_rpm", config_.speed * rpm)
      .add("critical_speed_rpm", config_.critical_speed * rpm)
      .add("critical_fraction", config_.speed / config_.critical_speed)
      .add("revolutions", static_cast<std::int64_t>(monitor_.revolutions().size()))
      .add("steady_revolutions", static_cast<std::int64_t>(monitor_.steady_revolutions()));
  // The whole run's energy audit against the drive work: (E - E0) + dissipated - drive work.
  const Real drive = world.wall_work();
  j.add("drive_work", drive).add("energy_balance_error", drive > 0 ? world.energy_balance().error / drive : 0.0);
  // No steady revolution yet: the means are absent rather than made up.
  if (const auto p = monitor_.mean_power_draw()) j.add("mean_power_draw", *p);
  if (const auto t = monitor_.mean_torque()) j.add("mean_torque", *t);
  return j;
}

void MillOutputs::write_spectra(const World& world) const {
  const CollisionSpectra* spectra = world.collision_spectra();
  if (!spectra) {
    if (!quiet_) std::printf("collision spectra: booked only with velocity Verlet\n");
    return;
  }
  write_spectra_csv(out_ / "spectra.csv", *spectra, world.time());  // rates over the run from t = 0 (resumed too)
  if (!quiet_ && spectra->class_count() > 1) {
    std::printf("collision spectra: share of the dissipation by size class (a mixed contact half to each):");
    for (int c = 0; c < spectra->class_count(); ++c)
      std::printf(" %s %.4g", spectra->class_name(c).c_str(), spectra->dissipation_share(c));
    std::printf("\n");
    std::fflush(stdout);  // before the plot script's own lines
  }
  run_plot_script("dem run", "plot_spectra.py", out_ / "spectra.csv", quiet_);
}

}  // namespace dem::cli

#include "engine/cli/mill_outputs.h"

#include <cstdio>

#include "engine/cli/plot_script.h"

namespace dem::cli {

namespace {

std::filesystem::path fresh(const std::filesystem::path& path, bool resuming) {
  if (!resuming) std::filesystem::remove(path);
  return path;
}

}  // namespace

MillOutputs::MillOutputs(const MillConfig& config, const World& world, const std::filesystem::path& out, bool resuming,
                         bool quiet)
    : config_(config),
      out_(out),
      start_time_(world.time()),
      monitor_(config, world),
      rows_(fresh(out / "mill.csv", resuming),
            {"time", "revolution", "torque", "power_draw", "toe_angle", "shoulder_angle"}),
      revolutions_(fresh(out / "mill_revolutions.csv", resuming),
                   {"end_time", "revolution", "start_time", "torque", "power_draw", "steady"}),
      quiet_(quiet) {
  if (resuming) {
    rows_.truncate_after(world.time());
    revolutions_.truncate_after(world.time());
  }
}

void MillOutputs::on_sync(const World& world) {
  for (const MillRevolution& r : monitor_.observe(world)) {
    revolutions_.append({r.end, static_cast<double>(r.index), r.start, r.torque, r.power_draw, r.steady ? 1.0 : 0.0});
    if (!quiet_)
      std::printf("revolution %d: t = %.4g to %.4g s, torque %.6g N m, power draw %.6g W%s\n", r.index, r.start, r.end,
                  r.torque, r.power_draw, r.steady ? "" : " (start-up, not averaged)");
  }
}

void MillOutputs::on_row(const World& world) {
  const MillRow r = monitor_.row(world);
  rows_.append({r.time, r.revolution, r.torque, r.power_draw, r.toe_angle, r.shoulder_angle});
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

void MillOutputs::write_spectra(const World& world, const std::string& scene_file) const {
  const CollisionSpectra* spectra = world.collision_spectra();
  if (!spectra) {
    if (!quiet_) std::printf("collision spectra: booked only under the fixed control with velocity Verlet\n");
    return;
  }
  spectra->write_csv(out_ / "spectra.csv", world.time() - start_time_);
  run_plot_script("dem run", "plot_spectra.py", scene_file, out_ / "spectra.csv", quiet_);
}

}  // namespace dem::cli

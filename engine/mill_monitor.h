#pragma once
// Measures a running mill (docs/physics.md 7.2, 7.3): drive power and torque from the work the mill's walls do
// on the charge (integrated every step by the World), per output interval and per revolution, the
// mean power over steady revolutions, and the charge's toe and shoulder angles.
//
// Angle convention (toe, shoulder): in the plane across the axis, measured from the horizontal
// through the axis on the side where the shell rises, positive in the sense of rotation, in
// degrees in (-180, 180]: the lowest point of the shell is -90. The charge spans from the toe (where
// it meets the shell, typically -150 to -110) up to the shoulder (where it leaves it, typically 20
// to 60). Both are the 5th and 95th percentiles of the angular distribution of the contact force
// on the shell and lifters, about its circular mean.
#include <optional>
#include <vector>

#include "engine/mill.h"
#include "engine/world.h"

namespace dem {

/// One output row of mill.csv; torque and power are means over the interval since the last row.
struct MillRow {
  Real time = 0;            // [s]
  Real drive_work = 0;      // since t = 0 [J]
  Real revolution = 0;      // revolutions turned so far (fractional) [-]
  Real torque = 0;          // drive torque, mean over the interval [N m]
  Real power_draw = 0;      // drive power, mean over the interval [W]
  Real toe_angle = 0;       // [degrees]; NaN when nothing touches the shell
  Real shoulder_angle = 0;  // [degrees]; NaN when nothing touches the shell
};

/// One completed revolution.
struct MillRevolution {
  int index = 0;          // 1 for the first
  Real start = 0, end = 0;  // sync times bracketing it [s]
  Real torque = 0;        // mean drive torque [N m]
  Real power_draw = 0;    // mean drive power [W]
  bool steady = false;    // after the ramp and the discarded revolutions: counts in mean_power_draw
  Real drive_work = 0;    // drive work done by its end since t = 0 [J]
};

class MillMonitor {
 public:
  /// `config` as the loader resolved it (speed, ramp, first_wall); starts counting at the world's time.
  MillMonitor(const MillConfig& config, const World& world);

  /// A resumed run: the revolutions and the last row written before the checkpoint (none: the
  /// run's start, where the drive work was 0), so the means continue as in an unbroken run.
  void resume(const std::vector<MillRevolution>& done, const std::optional<MillRow>& last_row);

  /// Call at every sync time: closes the revolutions completed since the last call; returns them.
  std::vector<MillRevolution> observe(const World& world);
  /// The row for the current sync time (interval means since the previous row).
  MillRow row(const World& world);

  const std::vector<MillRevolution>& revolutions() const { return revolutions_; }
  /// Mean power over the steady revolutions [W]; empty when none has completed.
  std::optional<Real> mean_power_draw() const;
  std::optional<Real> mean_torque() const;
  int steady_revolutions() const;

  /// Mill angle turned by time t [rad] (the ramp included).
  Real angle(Real t) const;

 private:
  MillConfig config_;
  Real rev_start_time_, rev_start_work_;
  int completed_ = 0;  // revolutions closed so far, counted from t = 0
  Real row_time_, row_work_;
  std::vector<MillRevolution> revolutions_;
};

/// Toe and shoulder angles [degrees] (convention above) from the contact forces on walls
/// [first, first + count); NaN when there are none.
std::pair<Real, Real> toe_and_shoulder(const World& world, std::size_t first, std::size_t count, int direction);

}  // namespace dem

#include "engine/mill_monitor.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace dem {

MillMonitor::MillMonitor(const MillConfig& config, const World& world) : config_(config) {
  rev_start_time_ = row_time_ = world.time();
  rev_start_work_ = row_work_ = world.wall_work();
  completed_ = static_cast<int>(std::floor(angle(world.time()) / (2 * pi) + 1e-12));
}

Real MillMonitor::angle(Real t) const { return config_.speed * ramp_distance(t, config_.ramp_time); }

std::vector<MillRevolution> MillMonitor::observe(const World& world) {
  std::vector<MillRevolution> closed;
  const Real t = world.time();
  const int turned = static_cast<int>(std::floor(angle(t) / (2 * pi) + 1e-12));
  if (turned <= completed_) return closed;
  // Several revolutions within one sync interval cannot be told apart: they share its mean.
  const Real work = world.wall_work();
  MillRevolution r;
  r.index = turned;
  r.start = rev_start_time_;
  r.end = t;
  const Real turned_angle = angle(t) - angle(rev_start_time_);
  r.power_draw = t > r.start ? (work - rev_start_work_) / (t - r.start) : 0;
  r.torque = turned_angle > 0 ? (work - rev_start_work_) / turned_angle : 0;
  const int ramp_revolutions = static_cast<int>(std::ceil(angle(config_.ramp_time) / (2 * pi) - 1e-12));
  r.steady = r.start >= config_.ramp_time && turned > ramp_revolutions + config_.discard_revolutions;
  r.drive_work = work;
  revolutions_.push_back(r);
  closed.push_back(r);
  completed_ = turned;
  rev_start_time_ = t;
  rev_start_work_ = work;
  return closed;
}

MillRow MillMonitor::row(const World& world) {
  MillRow row;
  row.time = world.time();
  row.revolution = angle(row.time) / (2 * pi);
  row.drive_work = world.wall_work();
  const Real work = world.wall_work() - row_work_;
  const Real turned = angle(row.time) - angle(row_time_);
  row.power_draw = row.time > row_time_ ? work / (row.time - row_time_) : 0;
  row.torque = turned > 0 ? work / turned : 0;
  // The shell and the lifters (the first 1 + lifters mill walls), not the end walls.
  const auto [toe, shoulder] = toe_and_shoulder(world, config_.first_wall, 1 + config_.lifters, config_.direction);
  row.toe_angle = toe;
  row.shoulder_angle = shoulder;
  row_time_ = row.time;
  row_work_ = world.wall_work();
  return row;
}

void MillMonitor::resume(const std::vector<MillRevolution>& done, const std::optional<MillRow>& last_row) {
  revolutions_ = done;
  completed_ = done.empty() ? 0 : done.back().index;
  rev_start_time_ = done.empty() ? 0 : done.back().end;
  rev_start_work_ = done.empty() ? 0 : done.back().drive_work;
  row_time_ = last_row ? last_row->time : 0;
  row_work_ = last_row ? last_row->drive_work : 0;
}

std::optional<Real> MillMonitor::mean_power_draw() const {
  Real work = 0, time = 0;
  for (const MillRevolution& r : revolutions_)
    if (r.steady) work += r.power_draw * (r.end - r.start), time += r.end - r.start;
  if (!(time > 0)) return std::nullopt;
  return work / time;
}

std::optional<Real> MillMonitor::mean_torque() const {
  const std::optional<Real> power = mean_power_draw();
  if (!power) return std::nullopt;
  return *power / config_.speed;
}

int MillMonitor::steady_revolutions() const {
  return static_cast<int>(std::count_if(revolutions_.begin(), revolutions_.end(), [](const MillRevolution& r) { return r.steady; }));
}

std::pair<Real, Real> toe_and_shoulder(const World& world, std::size_t first, std::size_t count, int direction) {
  const Real nan = std::numeric_limits<Real>::quiet_NaN();
  const Vec3 g = world.config().model.gravity;
  if (!(g.norm() > 0)) return {nan, nan};
  const Vec3 up = -g.normalized();
  const Vec3 rising = up.cross(direction * Vec3::UnitZ());  // horizontal, where the shell moves up
  const WallContacts& c = world.wall_contacts();
  struct Sample {
    Real angle, weight;
  };
  std::vector<Sample> samples;
  Real sx = 0, sy = 0, total = 0;
  for (std::size_t k = 0; k < c.size(); ++k) {
    if (c.wall[k] < first || c.wall[k] >= first + count) continue;
    const Real weight = c.force[k].norm();
    if (!(weight > 0)) continue;
    const Real a = std::atan2(c.point[k].dot(up), c.point[k].dot(rising));
    samples.push_back({a, weight});
    sx += weight * std::cos(a), sy += weight * std::sin(a), total += weight;
  }
  if (samples.empty()) return {nan, nan};
  // Unwrap about the circular mean so the charge's arc is contiguous, then take percentiles.
  const Real mean = std::atan2(sy, sx);
  for (Sample& s : samples) s.angle = mean + std::remainder(s.angle - mean, 2 * pi);
  std::sort(samples.begin(), samples.end(), [](const Sample& a, const Sample& b) { return a.angle < b.angle; });
  auto percentile = [&](Real fraction) {
    Real sum = 0;
    for (const Sample& s : samples) {
      sum += s.weight;
      if (sum >= fraction * total) return s.angle;
    }
    return samples.back().angle;
  };
  auto degrees = [](Real a) { return std::remainder(a, 2 * pi) * 180 / pi; };
  return {degrees(percentile(0.05)), degrees(percentile(0.95))};
}

}  // namespace dem

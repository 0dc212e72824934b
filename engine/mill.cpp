#include "engine/mill.h"

#include <cmath>
#include <numbers>

namespace dem {

Real critical_speed(Real mill_diameter, Real ball_diameter, Real gravity) {
  return std::sqrt(gravity / (0.5 * (mill_diameter - ball_diameter)));
}

std::size_t mill_wall_count(const MillConfig& config) {
  return 1 + static_cast<std::size_t>(config.lifters) + (config.dimension == 3 ? 2 : 0);
}

Real mill_free_radius(const MillConfig& config) {
  return 0.5 * config.diameter - (config.lifters > 0 ? config.lifter_height : 0);
}

std::vector<Vec3> lifter_profile(const MillConfig& config, int k) {
  const Real angle = 2 * std::numbers::pi * k / config.lifters;
  const Vec3 radial(std::cos(angle), std::sin(angle), 0), tangential(-std::sin(angle), std::cos(angle), 0);
  const Real R = 0.5 * config.diameter, h = config.lifter_height;
  const Real sink = 0.25 * h;  // base below the shell surface
  const Real slope = std::tan(config.lifter_face_angle * std::numbers::pi / 180);
  const Real top = 0.5 * config.lifter_width, base = top + (h + sink) * slope;
  return {(R + sink) * radial - base * tangential, (R + sink) * radial + base * tangential,
          (R - h) * radial + top * tangential, (R - h) * radial - top * tangential};
}

std::size_t add_mill_walls(const MillConfig& config, std::vector<WallConfig>& walls) {
  const std::size_t first = walls.size();
  const Vec3 omega = config.direction * config.speed * Vec3::UnitZ();
  auto turning = [&](WallConfig w) {
    w.material = config.material;
    w.angular_velocity = omega;
    w.rotation_center = Vec3::Zero();
    w.use_rotation_center = true;
    w.ramp_time = config.ramp_time;
    walls.push_back(w);
  };
  const bool slice = config.dimension == 2;
  WallConfig shell;
  shell.name = "shell";
  shell.kind = WallKind::cylinder;
  shell.axis = Vec3::UnitZ();
  shell.radius = 0.5 * config.diameter;
  if (!slice) shell.length = config.length;
  turning(shell);
  for (int k = 0; k < config.lifters; ++k) {
    WallConfig lifter;
    lifter.name = "lifter" + std::to_string(k + 1);
    lifter.kind = WallKind::prism;
    lifter.axis = Vec3::UnitZ();
    if (!slice) lifter.length = config.length;
    lifter.profile = lifter_profile(config, k);
    turning(lifter);
  }
  if (!slice)
    for (const Real side : {1.0, -1.0}) {
      WallConfig end;
      end.name = side > 0 ? "end_front" : "end_back";
      end.kind = WallKind::plane;
      end.point = Vec3(0, 0, side * 0.5 * config.length);
      end.normal = Vec3(0, 0, -side);
      turning(end);
    }
  return first;
}

}  // namespace dem

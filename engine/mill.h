#pragma once
// A grinding mill as a scene: a rotating cylindrical shell (axis z through the origin) with lifter
// bars and, in 3D, end walls, all turning together with a start-up ramp; the charge fills it.
// docs/physics.md section 7. add_mill_walls turns a MillConfig into plain prescribed-motion walls, so the
// engine needs nothing mill-specific; mill_monitor.h measures torque, power and the charge shape.
#include <string>
#include <vector>

#include "engine/config.h"

namespace dem {

struct MillConfig {
  Real diameter = 1;          // shell inside diameter D [m]
  Real length = 0.5;          // shell length between the end walls [m] (3D; a 2D slice has the disc thickness)
  int lifters = 0;            // lifter bars, evenly spaced, the first at angle 0 (the +x axis)
  Real lifter_height = 0;     // radial height above the shell [m]
  Real lifter_width = 0;      // width of the lifter's top face [m]
  Real lifter_face_angle = 0; // angle of each side face from the radial direction [degrees], in [0, 60]
  Real speed = 0;             // [rad/s], > 0; set by the loader from rpm or a fraction of critical
  Real critical_speed = 0;    // omega_c = sqrt(g / (D/2 - d/2)) for the mean ball diameter d [rad/s]
  int direction = 1;          // +1: counter-clockwise seen from +z (Omega along +z), -1: clockwise
  Real ramp_time = 0;         // start-up: the speed rises linearly from 0 over this time [s]
  int discard_revolutions = 2;  // complete revolutions after the ramp left out of mean_power_draw
  std::string material = "default";  // shell, lifters and end walls
  int dimension = 3;
  std::size_t first_wall = 0;  // index of the shell among the scene's walls (set by the loader)
};

/// Critical speed omega_c = sqrt(g / (R_mill - r_ball)) [rad/s] (docs/physics.md 7.1).
Real critical_speed(Real mill_diameter, Real ball_diameter, Real gravity);

/// Appends the mill's walls, named "shell", "lifter1".."lifterN" and, in 3D, "end_front" and "end_back",
/// all rotating about the z axis with the mill's speed, direction and ramp. Returns the index of the
/// first appended wall; the mill's walls are the `mill_wall_count(config)` walls from there.
std::size_t add_mill_walls(const MillConfig& config, std::vector<WallConfig>& walls);
std::size_t mill_wall_count(const MillConfig& config);

/// Corners of lifter `k`'s cross-section at t = 0 (z = 0), in order around it: the base sits a
/// little beyond the shell so no gap opens between them.
std::vector<Vec3> lifter_profile(const MillConfig& config, int k);

/// Radius inside which the charge can be placed: inside the lifter tips [m].
Real mill_free_radius(const MillConfig& config);

}  // namespace dem

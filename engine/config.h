#pragma once
// Plain structs a scene maps onto (scene_loader) or a program fills in code. Every field has a
// default and an SI unit. Nothing here computes: materials.cpp, walls.cpp and world.cpp turn these
// into run-time tables once, at set-up.
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "engine/types.h"

namespace dem {

/// When a normal contact stops pushing (docs/physics.md 2.1).
enum class Separation {
  force_zero,  ///< F_n = max(0, k delta + c delta_dot): no force after the force-zero instant (default)
  overlap,     ///< force until delta = 0, may turn attractive (LAMMPS gran/hooke convention)
};

/// When the rolling-resistance torque acts (docs/physics.md 2.4).
enum class RollingMode {
  standard,  ///< whenever the relative rolling velocity is non-zero, sliding included (default)
  seed,      ///< only while the contact is not sliding (Zhang & Whiten 2001)
};

/// How a damping value is given (docs/physics.md 2.2). Converted per contact with its effective mass.
enum class DampingKind {
  restitution,    ///< coefficient of restitution e in (0, 1], converted with the separation convention
  damping_ratio,  ///< zeta, dimensionless: c = 2 zeta sqrt(m k)
  coefficient,    ///< c [N s/m] directly
  tsuji_alpha,    ///< alpha, dimensionless: c = alpha sqrt(m k), i.e. zeta = alpha / 2
  gamma,          ///< LAMMPS/LIGGGHTS gamma [1/s], damping per unit effective mass: c = m* gamma
};

struct Damping {
  DampingKind kind = DampingKind::damping_ratio;
  Real value = 0;  // unit by kind: [-], [-], [N s/m], [-], [1/s]
};

struct MaterialConfig {
  std::string name = "default";
  Real density = 2500;  // [kg/m^3]
};

/// Contact parameters of one pair of materials (the linear spring-dashpot family).
/// Empty material names mean "every pair not listed otherwise".
struct ContactConfig {
  std::string material_a;
  std::string material_b;
  Real normal_stiffness = 1e5;    // k_n [N/m]
  Damping normal_damping;         // default: none
  Real tangential_stiffness = -1;  // k_t [N/m]; negative: 2/7 k_n (equal periods for solid spheres)
  Damping tangential_damping;      // default: none; restitution means "the same zeta as e gives normally"
  Real sliding_friction = 0;       // mu [-]; 0 together with static_friction 0: no tangential force
  Real static_friction = -1;       // mu_s [-] >= mu; negative: equal to mu
  Real rolling_friction = 0;       // mu_r [-]; 0 together with rolling_static 0: no rolling torque
  Real rolling_static_friction = -1;  // mu_rs [-]; negative: equal to mu_r
  Real rolling_stiffness = -1;     // k_r [N m/rad]; negative: k_t R*^2 (Ai et al. 2011 type C)
};

struct ModelConfig {
  int dimension = 3;             // 3: spheres; 2: discs in the xy plane
  Real thickness = 1;            // disc thickness for 2D masses [m]
  Vec3 gravity = Vec3::Zero();   // [m/s^2]
  Separation separation = Separation::force_zero;
  RollingMode rolling_mode = RollingMode::standard;
};

enum class WallKind {
  plane,     ///< half-space boundary: particles live on the side `normal` points to
  box,       ///< finite box: a container (inside = true) or a solid block (inside = false)
  cylinder,  ///< the inside of a cylinder (a mill shell), optionally of finite length
  prism,     ///< a solid convex polygon extruded along `axis` (a mill lifter bar)
  mesh,      ///< a triangle mesh (a liner from an STL file): particles live on its triangles' front side
};

class TriangleMesh;  // engine/triangle_mesh.h

/// A wall with prescribed motion: its geometry at time t is the t = 0 geometry translated by
/// velocity * s(t) and rotated by angle |angular_velocity| * s(t) about rotation_center (which moves
/// with the wall), where s(t) = t, or with a start-up ramp of ramp_time T the integral of a speed
/// rising linearly from 0 to full over T: s(t) = t^2 / 2T for t < T, t - T/2 after.
struct WallConfig {
  std::string name;
  WallKind kind = WallKind::plane;
  std::string material = "default";
  Vec3 point = Vec3::Zero();              // plane: a point on it; box: centre; cylinder: a point on the axis;
                                          // mesh: where the STL file's origin goes [m]
  Vec3 normal = Vec3::UnitZ();            // plane: unit normal into the particles' side
  Vec3 half_extents = Vec3::Ones();       // box: half edge lengths along x, y, z at t = 0 [m]
  bool inside = true;                     // box: particles inside (container) or outside (solid)
  Vec3 axis = Vec3::UnitZ();              // cylinder axis direction
  Real radius = 1;                        // cylinder inner radius [m]
  Real length = std::numeric_limits<Real>::infinity();  // cylinder, prism: length centred on `point` [m]
  std::vector<Vec3> profile;              // prism: corners of its convex cross-section at t = 0, in the
                                          // plane through `point` perpendicular to `axis` [m]
  std::string file;                       // mesh: the STL file the loader read `mesh` from (for messages)
  Real scale = 1;                         // mesh: metres per STL unit (0.001 for a file in mm) [m]
  std::shared_ptr<const TriangleMesh> mesh;  // mesh: triangles at t = 0 relative to `point` [m]; required
  Vec3 velocity = Vec3::Zero();           // [m/s]
  Vec3 angular_velocity = Vec3::Zero();   // [rad/s]
  Vec3 rotation_center = Vec3::Zero();    // [m], used when use_rotation_center, else `point`
  bool use_rotation_center = false;
  Real ramp_time = 0;                     // start-up: speeds rise linearly from 0 over this time [s]
};

struct ParticleConfig {
  // Stable id (what outputs and contact keys use). Nothing: the next id after the largest given so
  // far. A World adds particles in config order, each id above the last, so given ids must
  // increase along WorldConfig::particles (the scene loader sorts them).
  std::optional<ParticleId> id;
  Vec3 position = Vec3::Zero();          // [m]
  Vec3 velocity = Vec3::Zero();          // [m/s]
  Vec3 angular_velocity = Vec3::Zero();  // [rad/s]
  Real radius = 0;                       // [m]
  Real mass = 0;                         // [kg]; 0: from the density
  Real density = 0;                      // [kg/m^3]; 0: the material's density
  std::string material = "default";
};

enum class Method { verlet, exact };
enum class Control { fixed, doubling };

struct IntegratorConfig {
  Method method = Method::verlet;
  Control control = Control::fixed;
  Real dt = 1e-5;         // fixed step [s]
  Real dt_base = 0;       // level-0 step for doubling [s]; 0: equal to dt
  Real tolerance = 1e-2;  // doubling error tolerance [-] (seed formula (3) per step)
  int level_min = -10;
  int level_max = 10;
  Real safety = 0.8;
  Real velocity_weight = 1;
  Real dx_min = 1e-3;  // relative to the radius
  bool richardson = true;
  // false: seed formula (3), velocity errors weighted by the step; true: by the sync interval, with
  // the dx_min floor scaled by step / sync interval (error per unit step: the global error is then
  // proportional to the tolerance, at the price of finer steps; engine/step_control.h)
  bool error_per_unit_step = false;
  // Velocity Verlet's dashpots: false, the half-step velocity (first order in lasting damped
  // contacts); true, that velocity plus the previous forces' second half kick (second order, a tighter
  // stability limit: engine/forces.h DashpotVelocity). The exact stepper ignores it.
  bool predicted_dashpot = false;
  // Step doubling with velocity Verlet: false, an island steps at one level (its finest member's);
  // true, a level per particle inside the island (engine/particle_level_doubling.h).
  bool particle_levels = false;
};

struct BroadphaseConfig {
  Real skin = -1;       // neighbour skin [m]; negative: 10% of the smallest radius
  bool use_kd_tree = false;  // k-d tree instead of the grid (wide size ranges)
  bool wall_lists = true;    // per-particle lists of the walls within reach (wall_lists.h)
  // Fixed-step velocity Verlet: the particles are re-sorted in memory by spatial bins at the first
  // candidate rebuild and then at the first one at least this many steps after the last re-sort;
  // 0: never (slots stay in id order). Particles move the same bits either way.
  int sort_interval = 0;
};

struct WorldConfig {
  ModelConfig model;
  std::vector<MaterialConfig> materials{MaterialConfig{}};
  std::vector<ContactConfig> contacts{ContactConfig{}};
  std::vector<WallConfig> walls;
  std::vector<ParticleConfig> particles;
  IntegratorConfig integrator;
  BroadphaseConfig broadphase;
  int threads = 0;  // 0: the cores in the process's affinity mask
  bool collision_spectra = false;  // book contact events for energy spectra (velocity Verlet, either control)
  std::vector<double> spectra_size_classes;  // radius edges [m] of the spectra's size classes, ascending; empty: one class
};

}  // namespace dem

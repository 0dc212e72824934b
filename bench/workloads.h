#pragma once
// The two benchmark workloads of scenes/data/README.md, built in code from the shipped CSVs:
// a settled bed of 20,000 steel spheres and the same spheres in free flight at 0.5% solid fraction.
// Parameters exactly as documented there (overlap separation, gamma_n, gamma_t = gamma_n / 2, mu 0.5,
// skin 2 mm, dt 7.27e-6 s).
#include <string>

#include "engine/config.h"
#include "engine/particle_csv.h"

namespace dem::bench {

enum class Workload { dense_bed, free_flight };

inline WorldConfig benchmark_config(Workload workload, int threads) {
  WorldConfig c;
  c.threads = threads;
  c.model.gravity = Vec3(0, 0, -9.81);
  c.model.separation = Separation::overlap;
  c.materials = {MaterialConfig{"steel", 7800}};
  ContactConfig contact;
  contact.normal_stiffness = 1e6;
  contact.tangential_stiffness = 2.0 / 7.0 * 1e6;
  contact.normal_damping = {DampingKind::gamma, 9535.697};
  contact.tangential_damping = {DampingKind::gamma, 9535.697 / 2};
  contact.sliding_friction = 0.5;
  c.contacts = {contact};
  c.integrator.dt = 7.27e-6;
  c.broadphase.skin = 2e-3;
  const bool bed = workload == Workload::dense_bed;
  WallConfig box;
  box.name = "box";
  box.kind = WallKind::box;
  box.material = "steel";
  box.inside = true;
  box.half_extents = bed ? Vec3(0.15, 0.15, 0.2) : Vec3(0.6395, 0.6395, 0.6395);
  box.point = box.half_extents;
  c.walls = {box};
  const std::string file = std::string(DEM_SOURCE_DIR) + (bed ? "/scenes/data/dense_bed_settled.csv"
                                                              : "/scenes/data/free_flight_initial.csv");
  c.particles = read_particle_csv(file, "steel");
  return c;
}

}  // namespace dem::bench

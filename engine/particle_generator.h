#pragma once
// Seeded generators that fill a box or a cylinder with N particles of a size distribution without
// overlap (random sequential insertion). Random numbers are counter-based: a hash of (seed, particle,
// purpose, attempt), so the result depends on nothing but the settings. The placed particles are
// then numbered along a space-filling curve, so neighbours in space are neighbours in memory.
#include <cstdint>
#include <string>
#include <vector>

#include "engine/config.h"

namespace dem {

enum class GeneratorRegion { box, cylinder };
enum class SizeDistribution { mono, uniform, normal, lognormal };

struct GeneratorConfig {
  int count = 0;
  std::uint64_t seed = 1;
  std::string material = "default";
  Vec3 velocity = Vec3::Zero();    // [m/s]
  int max_attempts = 1000;         // placements tried per particle before giving up
  int dimension = 3;               // 2: centres in the plane z = 0
  GeneratorRegion region = GeneratorRegion::box;
  Vec3 min = Vec3::Zero(), max = Vec3::Ones();     // box corners [m]
  Vec3 center = Vec3::Zero(), axis = Vec3::UnitZ(); // cylinder
  Real radius = 1, length = 0;                      // cylinder radius and length [m]
  SizeDistribution distribution = SizeDistribution::mono;
  Real mean = 0;   // mono: the radius; normal: mean; lognormal: median [m]
  Real sigma = 0;  // normal: standard deviation [m]; lognormal: sigma of ln r [-]
  Real r_min = 0, r_max = 0;  // truncation [m]
};

struct GeneratorResult {
  bool ok = true;
  std::string message;
};

/// Mean of r^k over the configured (truncated) radius distribution [m^k], e.g. k = 3 for the mean
/// sphere volume over 4 pi / 3.
Real radius_moment(const GeneratorConfig& config, int k);

/// Appends `count` non-overlapping particles, wholly inside the region, to `particles` (which may
/// already hold particles to avoid), in the order of order_along_curve. Fails with a message when the
/// region is too full.
GeneratorResult generate_particles(const GeneratorConfig& config, std::vector<ParticleConfig>& particles);

/// Reorders particles[first ..] along a Morton (Z-order) curve through their centres, ties in their
/// present order, so that particles near each other in space get nearby ids, and so nearby slots: the
/// force loops then read partners close in memory, and two threads share few cache lines. Positions
/// are quantised to 1,024 cells per axis of the group's bounding cube.
void order_along_curve(std::vector<ParticleConfig>& particles, std::size_t first);

}  // namespace dem

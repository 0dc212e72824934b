#pragma once
// Basic types shared by every engine file: the scalar, vectors, and the two particle index kinds.
#include <Eigen/Core>
#include <cstdint>

namespace dem {

using Real = double;
using Vec3 = Eigen::Matrix<Real, 3, 1>;

/// Stable particle identifier: what users, contact keys and outputs see.
using ParticleId = std::uint32_t;
/// Storage slot of a particle in the State arrays (may change when particles are reordered).
using ParticleIndex = std::uint32_t;

/// Contact key of a particle pair: the smaller id in the high 32 bits, the larger in the low.
inline std::uint64_t pair_key(ParticleId a, ParticleId b) {
  const ParticleId lo = a < b ? a : b;
  const ParticleId hi = a < b ? b : a;
  return (std::uint64_t{lo} << 32) | hi;
}

/// Contact key of a particle touching feature `feature` of wall `wall`.
inline std::uint64_t wall_key(ParticleId particle, std::uint32_t wall, std::uint32_t feature) {
  return (std::uint64_t{particle} << 32) | (std::uint64_t{wall} << 8) | feature;
}

inline constexpr Real pi = 3.14159265358979323846;

}  // namespace dem

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

/// A wall and one of its features packed in 31 bits (bit 31 stays free for the exact stepper's flag):
/// feature ids below 2^22 (a triangle mesh has one per face, edge and vertex), wall indices below 2^9.
inline constexpr int wall_feature_bits = 22;
inline constexpr std::uint32_t max_wall_features = std::uint32_t{1} << wall_feature_bits;
inline constexpr std::uint32_t max_walls = std::uint32_t{1} << 9;
inline std::uint32_t wall_feature_code(std::uint32_t wall, std::uint32_t feature) {
  return (wall << wall_feature_bits) | feature;
}

/// Contact key of a particle touching feature `feature` of wall `wall`.
inline std::uint64_t wall_key(ParticleId particle, std::uint32_t wall, std::uint32_t feature) {
  return (std::uint64_t{particle} << 32) | wall_feature_code(wall, feature);
}

inline constexpr Real pi = 3.14159265358979323846;

}  // namespace dem

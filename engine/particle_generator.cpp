#include "engine/particle_generator.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <utility>

#include <Eigen/Geometry>

#include "engine/hash_mix.h"
#include "engine/spatial_order.h"

namespace dem {
namespace {

double uniform01(std::uint64_t seed, std::uint64_t a, std::uint64_t b, std::uint64_t c) {
  // The seed is mixed before the first counter is added: otherwise seed s and particle n + 1 would
  // draw what seed s + 1 and particle n draw, and two seeds would place nearly the same particles.
  std::uint64_t z = splitmix64_mix(seed + 0x9E3779B97F4A7C15ull);
  for (std::uint64_t v : {a, b, c}) z = splitmix64_mix(z + 0x9E3779B97F4A7C15ull + v);
  return (static_cast<double>(z >> 11) + 0.5) * 0x1.0p-53;  // in (0, 1)
}

enum Purpose : std::uint64_t { size_draw = 1, place_x = 2, place_y = 3, place_z = 4 };

double standard_normal(std::uint64_t seed, std::uint64_t particle, std::uint64_t attempt) {
  const double u1 = uniform01(seed, particle, size_draw, 2 * attempt);
  const double u2 = uniform01(seed, particle, size_draw, 2 * attempt + 1);
  return std::sqrt(-2 * std::log(u1)) * std::cos(2 * pi * u2);  // Box-Muller
}

Real draw_radius(const GeneratorConfig& g, std::uint64_t particle) {
  switch (g.distribution) {
    case SizeDistribution::mono:
      return g.mean;
    case SizeDistribution::uniform:
      return g.r_min + (g.r_max - g.r_min) * uniform01(g.seed, particle, size_draw, 0);
    case SizeDistribution::normal:
    case SizeDistribution::lognormal:
      for (std::uint64_t attempt = 0; attempt < 10000; ++attempt) {  // truncation by rejection
        const double z = standard_normal(g.seed, particle, attempt);
        const Real r = g.distribution == SizeDistribution::normal ? g.mean + g.sigma * z : g.mean * std::exp(g.sigma * z);
        if (r >= g.r_min && r <= g.r_max) return r;
      }
      return 0.5 * (g.r_min + g.r_max);
  }
  return g.mean;
}

/// Hashed cell grid of the placed particles for overlap queries.
struct PlacementGrid {
  Real cell;
  std::unordered_map<std::uint64_t, std::vector<std::size_t>> cells;
  static std::uint64_t key(std::int64_t x, std::int64_t y, std::int64_t z) {
    return (static_cast<std::uint64_t>(x) * 73856093ull) ^ (static_cast<std::uint64_t>(y) * 19349663ull) ^
           (static_cast<std::uint64_t>(z) * 83492791ull);
  }
  // Clamped like the broadphase grid's cells: a finite but huge position (1e307 m) would overflow the
  // conversion to int64; far particles then share an edge cell, and the distance test stays exact.
  std::int64_t coord(Real v) const {
    constexpr Real limit = 0x1p52;
    Real q = std::floor(v / cell);
    if (!(q >= -limit)) q = -limit;  // also maps NaN
    if (q > limit) q = limit;
    return static_cast<std::int64_t>(q);
  }
  void insert(const Vec3& x, std::size_t p) { cells[key(coord(x.x()), coord(x.y()), coord(x.z()))].push_back(p); }
  bool overlaps(const Vec3& x, Real r, const std::vector<ParticleConfig>& ps) const {
    const std::int64_t cx = coord(x.x()), cy = coord(x.y()), cz = coord(x.z());
    for (std::int64_t i = cx - 1; i <= cx + 1; ++i)
      for (std::int64_t j = cy - 1; j <= cy + 1; ++j)
        for (std::int64_t k = cz - 1; k <= cz + 1; ++k) {
          const auto it = cells.find(key(i, j, k));
          if (it == cells.end()) continue;
          for (std::size_t p : it->second) {
            const Real reach = r + ps[p].radius;
            if ((ps[p].position - x).squaredNorm() < reach * reach) return true;
          }
        }
    return false;
  }
};

}  // namespace

Real radius_moment(const GeneratorConfig& g, int k) {
  const Real a = g.r_min, b = g.r_max;
  if (g.distribution == SizeDistribution::mono || !(b > a)) return std::pow(g.mean > 0 ? g.mean : a, k);
  if (g.distribution == SizeDistribution::uniform) return (std::pow(b, k + 1) - std::pow(a, k + 1)) / ((k + 1) * (b - a));
  // Truncated normal or lognormal: Simpson's rule on the density (unnormalised) over [a, b].
  auto density = [&](Real r) {
    if (g.distribution == SizeDistribution::normal) return g.sigma > 0 ? std::exp(-0.5 * std::pow((r - g.mean) / g.sigma, 2)) : Real(r == g.mean);
    return g.sigma > 0 ? std::exp(-0.5 * std::pow(std::log(r / g.mean) / g.sigma, 2)) / r : Real(r == g.mean);
  };
  if (!(g.sigma > 0)) return std::pow(std::clamp(g.mean, a, b), k);
  const int n = 2000;
  Real weight = 0, moment = 0;
  for (int i = 0; i <= n; ++i) {
    const Real r = a + (b - a) * i / n;
    const Real w = (i == 0 || i == n ? 1 : (i % 2 ? 4 : 2)) * density(r);
    weight += w;
    moment += w * std::pow(r, k);
  }
  return moment / weight;
}

GeneratorResult generate_particles(const GeneratorConfig& g, std::vector<ParticleConfig>& particles) {
  Real largest = g.r_max > 0 ? g.r_max : g.mean;
  for (const auto& p : particles) largest = std::max(largest, p.radius);
  PlacementGrid grid{2 * largest, {}};
  for (std::size_t p = 0; p < particles.size(); ++p) grid.insert(particles[p].position, p);
  const Vec3 axis = g.axis.normalized();
  const Vec3 u = axis.unitOrthogonal(), v = axis.cross(u);
  for (int n = 0; n < g.count; ++n) {
    const Real r = draw_radius(g, static_cast<std::uint64_t>(n));
    bool placed = false;
    for (int attempt = 0; attempt < g.max_attempts && !placed; ++attempt) {
      const auto a = static_cast<std::uint64_t>(attempt);
      const double s1 = uniform01(g.seed, n, place_x, a), s2 = uniform01(g.seed, n, place_y, a),
                   s3 = uniform01(g.seed, n, place_z, a);
      Vec3 x;
      if (g.region == GeneratorRegion::box) {
        const Vec3 lo = g.min + Vec3::Constant(r), hi = g.max - Vec3::Constant(r);
        const Vec3 room = hi - lo;
        if (room.x() < 0 || room.y() < 0 || (g.dimension == 3 && room.z() < 0))
          return {false, "the box is smaller than a particle of radius " + std::to_string(r)};
        x = lo + Vec3(s1, s2, s3).cwiseProduct(hi - lo);
      } else {
        const Real rho_max = g.radius - r;
        if (rho_max < 0) return {false, "the cylinder is narrower than a particle of radius " + std::to_string(r)};
        const Real rho = rho_max * std::sqrt(s1), phi = 2 * pi * s2;
        const Real half = std::max(Real{0}, 0.5 * g.length - r);
        x = g.center + rho * (std::cos(phi) * u + std::sin(phi) * v) + (2 * s3 - 1) * half * axis;
      }
      if (g.dimension == 2) x.z() = 0;
      if (grid.overlaps(x, r, particles)) continue;
      ParticleConfig p;
      p.position = x;
      p.radius = r;
      p.velocity = g.velocity;
      p.material = g.material;
      grid.insert(x, particles.size());
      particles.push_back(p);
      placed = true;
    }
    if (!placed)
      return {false, "placed only " + std::to_string(n) + " of " + std::to_string(g.count) +
                         " particles without overlap: enlarge the region, reduce count or raise max_attempts"};
  }
  order_along_curve(particles, particles.size() - static_cast<std::size_t>(g.count));
  return {};
}

void order_along_curve(std::vector<ParticleConfig>& particles, std::size_t first) {
  if (particles.size() <= first + 1) return;
  std::vector<Vec3> centres;
  centres.reserve(particles.size() - first);
  for (std::size_t q = first; q < particles.size(); ++q) centres.push_back(particles[q].position);
  std::vector<ParticleConfig> sorted;
  sorted.reserve(centres.size());
  for (std::uint32_t q : curve_order(centres)) sorted.push_back(std::move(particles[first + q]));
  std::move(sorted.begin(), sorted.end(), particles.begin() + static_cast<std::ptrdiff_t>(first));
}

}  // namespace dem

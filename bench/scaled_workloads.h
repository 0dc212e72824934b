#pragma once
// The two benchmark workloads of bench/workloads.h at any particle count N, for the cost-against-N
// report. Physics, material and step are those of benchmark_config; only the
// particles and the box change:
//  - N below the shipped 20,000: the N particles nearest the box's origin corner, ranked by how far
//    their far side reaches along x, y and z, each as a fraction of the box (of the bed's height for
//    the bed); the box shrinks in x and y (and z for the gas) to the farthest kept reach, so it holds
//    every kept particle: a corner block of the settled bed, as wide as it is a fraction of the bed's
//    height (a narrow full-height column relaxes and loses most of its contacts), or a smaller cube
//    of the same gas.
//  - N above: copies of the shipped block laid side by side in x and y, each shifted by the block's
//    extent (0.3 m for the bed, 1.279 m for the gas), in a box as wide as the tiling, then ranked as
//    above. The bed stays a settled bed (walls between copies simply removed) and the gas keeps its
//    density.
// Blocks per axis for k = ceil(N / 20,000) blocks: nx x ny = k with ny the largest divisor of k not
// above sqrt(k), unless that leaves a strip more than 4 blocks long (a prime k), when it is the
// near-square nx x ny >= k cut down to N as above: 50 blocks tile 10 x 5; 5 tile 3 x 2, cut to 100,000.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <map>
#include <numeric>
#include <vector>

#include "bench/workloads.h"

namespace dem::bench {

/// The shipped 20,000-particle configuration of a workload, read once per process.
inline const WorldConfig& shipped_block(Workload workload) {
  static std::map<Workload, WorldConfig> cache;
  auto it = cache.find(workload);
  if (it == cache.end()) it = cache.emplace(workload, benchmark_config(workload, 1)).first;
  return it->second;
}

/// The workload with exactly `n` particles (n >= 1) and `threads` threads, as described above.
inline WorldConfig scaled_config(Workload workload, std::size_t n, int threads) {
  const WorldConfig& block = shipped_block(workload);
  WorldConfig c = block;
  c.threads = threads;
  const std::size_t block_n = block.particles.size();
  const Vec3 extent = 2 * block.walls.at(0).half_extents;  // the box is [0, extent] per axis [m]
  const std::size_t k = (n + block_n - 1) / block_n;
  std::size_t ny = 1;
  for (std::size_t d = 1; d * d <= k; ++d)
    if (k % d == 0) ny = d;
  std::size_t nx = k / ny;
  if (nx > 4 * ny) {  // a prime count: near-square tiling with a few spare blocks
    ny = static_cast<std::size_t>(std::floor(std::sqrt(static_cast<double>(k))));
    nx = (k + ny - 1) / ny;
  }
  std::vector<ParticleConfig> tiled;
  tiled.reserve(nx * ny * block_n);
  for (std::size_t by = 0; by < ny; ++by)
    for (std::size_t bx = 0; bx < nx; ++bx)
      for (ParticleConfig p : block.particles) {
        p.id.reset();  // copies and subsets are numbered afresh, in the order kept below
        p.position += Vec3(static_cast<Real>(bx) * extent.x(), static_cast<Real>(by) * extent.y(), 0);
        tiled.push_back(p);
      }
  const Vec3 box(static_cast<Real>(nx) * extent.x(), static_cast<Real>(ny) * extent.y(), extent.z());
  // Reach along z: against the box for the gas, against the bed's top for the bed (whose box keeps its
  // height, the bed's top surface being free anyway).
  const bool scale_z = workload == Workload::free_flight;
  Real z_ref = box.z();
  if (!scale_z) {
    z_ref = 0;
    for (const ParticleConfig& p : tiled) z_ref = std::max(z_ref, p.position.z() + p.radius);
  }
  auto reach = [&](const ParticleConfig& p) {
    return std::max({(p.position.x() + p.radius) / box.x(), (p.position.y() + p.radius) / box.y(),
                     (p.position.z() + p.radius) / z_ref});
  };
  std::vector<Real> key(tiled.size());
  for (std::size_t q = 0; q < tiled.size(); ++q) key[q] = reach(tiled[q]);
  std::vector<std::size_t> order(tiled.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  n = std::min(n, tiled.size());
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return key[a] < key[b]; });
  order.resize(n);
  std::sort(order.begin(), order.end());  // keep the file's order (ids) among the kept particles
  c.particles.clear();
  for (std::size_t q : order) c.particles.push_back(tiled[q]);
  // Whole tilings keep the tiled box exactly; a subset shrinks it to the farthest kept reach.
  Real scale = 1;
  if (n < tiled.size()) {
    scale = 0;
    for (std::size_t q : order) scale = std::max(scale, key[q]);
  }
  Vec3 half = 0.5 * box;
  half.x() *= scale;
  half.y() *= scale;
  if (scale_z) half.z() *= scale;
  c.walls.at(0).half_extents = half;
  c.walls.at(0).point = half;
  return c;
}

}  // namespace dem::bench

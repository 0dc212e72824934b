// Long broadphase validation (ctest label `long`): a million particles over huge domains, grid against
// k-d tree for exact equality of the CSR. Brute force is out of reach at this size; the two fast
// implementations share nothing but the predicate, so agreement is the check.
#include "broadphase/grid.h"
#include "broadphase/kd_tree.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace dem::broadphase {
namespace {

struct Particles {
  std::vector<Vec3> position;  // [m]
  std::vector<double> radius;  // [m]
};

// Adds n particles uniform in the cube [corner, corner + side], radii uniform in [r_lo, r_hi].
void add_random_cube(Particles& p, std::size_t n, const Vec3& corner, double side, double r_lo, double r_hi,
                     std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 u(unit(rng), unit(rng), unit(rng));
    p.position.push_back(corner + side * u);
    p.radius.push_back(r_lo + (r_hi - r_lo) * unit(rng));
  }
}

void expect_grid_matches_kd_tree(const Particles& p, double skin, std::size_t min_pairs) {
  CandidatePairs grid_pairs, tree_pairs;
  GridBroadphase().find_pairs(p.position, p.radius, skin, grid_pairs);
  KdTreeBroadphase().find_pairs(p.position, p.radius, skin, tree_pairs);
  EXPECT_TRUE(is_valid(grid_pairs, p.position.size()));
  EXPECT_TRUE(is_valid(tree_pairs, p.position.size()));
  EXPECT_GE(grid_pairs.pair_count(), min_pairs);  // the dense part is really dense
  EXPECT_TRUE(grid_pairs.row_start == tree_pairs.row_start);
  EXPECT_TRUE(grid_pairs.partner == tree_pairs.partner);
  testing::Test::RecordProperty("pairs", static_cast<int>(grid_pairs.pair_count()));
}

TEST(BroadphaseLong, GridMatchesKdTreeOnAMillionParticlesInA10kmCube) {
  Particles p;
  add_random_cube(p, 900000, Vec3::Constant(-5e3), 1e4, 0.5, 2.0, 1);
  add_random_cube(p, 100000, Vec3(1234.5, -2e3, 4e3), 150.0, 0.5, 2.0, 2);  // dense sub-cluster
  expect_grid_matches_kd_tree(p, 0.2, 100000);
}

TEST(BroadphaseLong, GridMatchesKdTreeOnAMillionParticlesInA1000kmCube) {
  Particles p;
  add_random_cube(p, 900000, Vec3::Constant(-5e5), 1e6, 0.5, 2.0, 3);
  add_random_cube(p, 100000, Vec3(-4.9e5, 3e5, 4.9e5), 150.0, 0.5, 2.0, 4);
  expect_grid_matches_kd_tree(p, 0.2, 100000);
}

}  // namespace
}  // namespace dem::broadphase

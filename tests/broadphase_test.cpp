// Broadphase tests: every implementation against the brute-force oracle, on random and adversarial
// inputs, for exact equality of the CSR; determinism across thread counts and repeated calls; the skin.
#include "broadphase/brute_force.h"
#include "broadphase/grid.h"
#include "broadphase/kd_tree.h"
#include "broadphase/parallel.h"
#include "broadphase/skin.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cfloat>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <new>
#include <numbers>
#include <random>
#include <sstream>
#include <string>
#include <vector>

// Counts global operator new calls, so a test can show the grid allocates nothing after warm-up. Not
// in sanitizer builds, whose runtime defines operator new itself (the test is skipped there).
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define DEM_COUNTS_ALLOCATIONS 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define DEM_COUNTS_ALLOCATIONS 0
#endif
#endif
#ifndef DEM_COUNTS_ALLOCATIONS
#define DEM_COUNTS_ALLOCATIONS 1
#endif

namespace {
std::atomic<long> allocation_count{0};
}  // namespace

#if DEM_COUNTS_ALLOCATIONS
// Out of line, so GCC does not pair the inlined free with operator new (-Wmismatched-new-delete).
[[gnu::noinline]] void* operator new(std::size_t size) {
  allocation_count.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
[[gnu::noinline]] void operator delete(void* p) noexcept { std::free(p); }
[[gnu::noinline]] void operator delete(void* p, std::size_t) noexcept { std::free(p); }
#endif

namespace dem::broadphase {
namespace {

struct Particles {
  std::vector<Vec3> position;  // [m]
  std::vector<double> radius;  // [m]

  std::size_t size() const { return position.size(); }
  void add(const Vec3& x, double r) {
    position.push_back(x);
    radius.push_back(r);
  }
  void append(const Particles& other) {
    position.insert(position.end(), other.position.begin(), other.position.end());
    radius.insert(radius.end(), other.radius.begin(), other.radius.end());
  }
};

// n particles uniform in the box [lo, hi]; radii uniform in [r_lo, r_hi], or log-uniform.
Particles random_box(std::size_t n, const Vec3& lo, const Vec3& hi, double r_lo, double r_hi, std::uint64_t seed,
                     bool log_radii = false) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Particles p;
  for (std::size_t i = 0; i < n; ++i) {
    Vec3 x;
    for (int a = 0; a < 3; ++a) x[a] = lo[a] + (hi[a] - lo[a]) * unit(rng);
    const double u = unit(rng);
    const double r = log_radii ? r_lo * std::pow(r_hi / r_lo, u) : r_lo + (r_hi - r_lo) * u;
    p.add(x, r);
  }
  return p;
}

// Side of the cube that n spheres of radius r fill to `fraction` (overlaps ignored).
double cube_side(std::size_t n, double r, double fraction) {
  return std::cbrt(static_cast<double>(n) * 4.0 / 3.0 * std::numbers::pi * r * r * r / fraction);
}

CandidatePairs oracle(const Particles& p, double skin) {
  CandidatePairs pairs;
  BruteForceBroadphase().find_pairs(p.position, p.radius, skin, pairs);
  return pairs;
}

std::string row_text(const CandidatePairs& pairs, std::size_t i) {
  std::ostringstream s;
  s << "{";
  for (std::size_t k = pairs.row_start[i]; k < pairs.row_start[i + 1]; ++k) s << " " << pairs.partner[k];
  s << " }";
  return s.str();
}

// Exact equality of both CSR vectors, reporting the first differing row rather than whole vectors.
testing::AssertionResult same_pairs(const CandidatePairs& got, const CandidatePairs& expected) {
  if (got.row_start == expected.row_start && got.partner == expected.partner) {
    return testing::AssertionSuccess();
  }
  if (got.row_start.size() != expected.row_start.size()) {
    return testing::AssertionFailure() << "rows: " << got.row_count() << " vs " << expected.row_count();
  }
  for (std::size_t i = 0; i < got.row_count(); ++i) {
    if (row_text(got, i) != row_text(expected, i)) {
      return testing::AssertionFailure() << "row " << i << ": got " << row_text(got, i) << ", expected "
                                         << row_text(expected, i) << " (pairs " << got.pair_count() << " vs "
                                         << expected.pair_count() << ")";
    }
  }
  return testing::AssertionFailure() << "offsets differ though rows agree";
}

template <class Broadphase>
class BroadphaseMatchesOracle : public testing::Test {
 protected:
  // Returns the pairs so a test can add its own checks.
  CandidatePairs expect_matches_oracle(const Particles& p, double skin) {
    Broadphase broadphase;
    CandidatePairs got;
    broadphase.find_pairs(p.position, p.radius, skin, got);
    EXPECT_TRUE(is_valid(got, p.size()));
    EXPECT_TRUE(same_pairs(got, oracle(p, skin)));
    return got;
  }
};

struct ImplementationName {
  template <class T>
  static std::string GetName(int) {
    if constexpr (std::is_same_v<T, GridBroadphase>) return "Grid";
    return "KdTree";
  }
};
using Implementations = testing::Types<GridBroadphase, KdTreeBroadphase>;
TYPED_TEST_SUITE(BroadphaseMatchesOracle, Implementations, ImplementationName);

TYPED_TEST(BroadphaseMatchesOracle, RandomMonodisperse) {
  const std::size_t n = 20000;
  const double side = cube_side(n, 0.5, 0.4);
  const auto pairs = this->expect_matches_oracle(random_box(n, Vec3::Zero(), Vec3::Constant(side), 0.5, 0.5, 1), 0.1);
  EXPECT_GT(pairs.pair_count(), n);  // the case is not vacuous
}

TYPED_TEST(BroadphaseMatchesOracle, PolydisperseRadiiSpanning100x) {
  const std::size_t n = 8000;
  const double side = cube_side(n, 0.2, 0.3);
  this->expect_matches_oracle(random_box(n, Vec3::Zero(), Vec3::Constant(side), 0.01, 1.0, 2, true), 0.02);
}

TYPED_TEST(BroadphaseMatchesOracle, DenseClusters) {
  Particles p;
  for (int c = 0; c < 5; ++c) {
    const Vec3 corner(7.0 * c, -3.0 * c, 2.0 * c);
    p.append(random_box(800, corner, corner + Vec3::Constant(2.0), 0.3, 0.5, 10 + c));
  }
  p.append(random_box(2000, Vec3::Constant(-20.0), Vec3::Constant(40.0), 0.3, 0.5, 20));  // sparse background
  const auto pairs = this->expect_matches_oracle(p, 0.05);
  EXPECT_GT(pairs.pair_count(), 200000u);
}

TYPED_TEST(BroadphaseMatchesOracle, EmptyInput) {
  const auto pairs = this->expect_matches_oracle(Particles{}, 0.1);
  EXPECT_EQ(pairs.row_start, std::vector<std::uint32_t>{0});
  EXPECT_TRUE(pairs.partner.empty());
}

TYPED_TEST(BroadphaseMatchesOracle, OneParticle) {
  Particles p;
  p.add(Vec3(1.0, -2.0, 3.0), 0.5);
  const auto pairs = this->expect_matches_oracle(p, 0.1);
  EXPECT_EQ(pairs.row_start, (std::vector<std::uint32_t>{0, 0}));
}

TYPED_TEST(BroadphaseMatchesOracle, AllCoincidentCentres) {
  Particles p = random_box(500, Vec3::Zero(), Vec3::Zero(), 0.1, 0.7, 3);
  for (auto& x : p.position) x = Vec3(3.7, -2.1, 1e3);
  const auto pairs = this->expect_matches_oracle(p, 0.0);
  EXPECT_EQ(pairs.pair_count(), 500u * 499u / 2u);
}

TYPED_TEST(BroadphaseMatchesOracle, ZeroRadiiAndZeroSkinPairOnlyCoincidentCentres) {
  std::mt19937_64 rng(4);
  std::uniform_int_distribution<int> coordinate(-1, 1);
  Particles p;
  for (int i = 0; i < 1000; ++i) p.add(Vec3(coordinate(rng), coordinate(rng), coordinate(rng)), 0.0);
  const auto pairs = this->expect_matches_oracle(p, 0.0);
  EXPECT_GT(pairs.pair_count(), 0u);
}

// Lattice of spacing = reach = 2r + skin: every face neighbour is a candidate at exactly the reach,
// and each coordinate is nudged by one ulp either way or not at all, to straddle the cell faces.
Particles face_lattice(double spacing, double radius, int half_width, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> nudge(-1, 1);
  const auto nudged = [&](double x) {
    const int d = nudge(rng);
    return d == 0 ? x : std::nextafter(x, d * std::numeric_limits<double>::infinity());
  };
  Particles p;
  for (int i = -half_width; i <= half_width; ++i) {
    for (int j = -half_width; j <= half_width; ++j) {
      for (int k = -half_width; k <= half_width; ++k) {
        p.add(Vec3(nudged(i * spacing), nudged(j * spacing), nudged(k * spacing)), radius);
      }
    }
  }
  return p;
}

TYPED_TEST(BroadphaseMatchesOracle, CentresExactlyOnCellFaces) {
  const double radius = 0.5, skin = 0.25;  // cell size 1.25, exact in binary
  Particles exact;
  for (int i = -8; i <= 8; ++i) {
    for (int j = -8; j <= 8; ++j) {
      for (int k = -8; k <= 8; ++k) exact.add(Vec3(i, j, k) * (2 * radius + skin), radius);
    }
  }
  const auto pairs = this->expect_matches_oracle(exact, skin);
  EXPECT_EQ(pairs.pair_count(), 3u * 16u * 17u * 17u);  // face neighbours only
  this->expect_matches_oracle(face_lattice(2 * radius + skin, radius, 8, 5), skin);
  this->expect_matches_oracle(face_lattice(2 * 0.3 + 0.07, 0.3, 8, 6), 0.07);  // spacing not exact
}

TYPED_TEST(BroadphaseMatchesOracle, CentresOnTheGridsOwnCellFaces) {
  // Points at multiples of half the grid's actual (slightly widened) cell size: every other plane is a
  // cell face of the grid itself.
  const double radius = 0.3, skin = 0.07;
  Particles probe;
  probe.add(Vec3::Zero(), radius);
  GridBroadphase grid;
  CandidatePairs ignored;
  grid.find_pairs(probe.position, probe.radius, skin, ignored);
  const double half_cell = 0.5 * grid.cell_size();
  Particles p;
  for (int i = -7; i <= 7; ++i) {
    for (int j = -7; j <= 7; ++j) {
      for (int k = -7; k <= 7; ++k) p.add(Vec3(i * half_cell, j * half_cell, k * half_cell), radius);
    }
  }
  const auto pairs = this->expect_matches_oracle(p, skin);
  EXPECT_GT(pairs.pair_count(), 0u);
}

TYPED_TEST(BroadphaseMatchesOracle, OneHugeParticleAmongSmallOnes) {
  Particles p = random_box(2000, Vec3::Zero(), Vec3::Constant(1.5), 0.01, 0.05, 7);
  p.position[1000] = Vec3(0.4, 0.5, 0.6);
  p.radius[1000] = 0.6;
  const auto pairs = this->expect_matches_oracle(p, 0.01);
  std::size_t huge_partners = pairs.row_start[1001] - pairs.row_start[1000];
  for (std::size_t i = 0; i < 1000; ++i) {
    for (std::size_t k = pairs.row_start[i]; k < pairs.row_start[i + 1]; ++k) huge_partners += pairs.partner[k] == 1000;
  }
  EXPECT_GT(huge_partners, 100u);
  EXPECT_LT(huge_partners, 1999u);
}

TYPED_TEST(BroadphaseMatchesOracle, TwoDimensionalInput) {
  const std::size_t n = 10000;
  const double side = std::sqrt(static_cast<double>(n) * std::numbers::pi * 0.25 / 0.5);  // discs, 50 %
  const auto pairs = this->expect_matches_oracle(random_box(n, Vec3::Zero(), Vec3(side, side, 0.0), 0.5, 0.5, 8), 0.1);
  EXPECT_GT(pairs.pair_count(), n);
}

TYPED_TEST(BroadphaseMatchesOracle, NegativeAndLargeCoordinates) {
  const Vec3 offset(-1e5, 1e5, -1e5);
  const auto pairs =
      this->expect_matches_oracle(random_box(10000, offset, offset + Vec3::Constant(20.0), 0.2, 0.6, 9), 0.05);
  EXPECT_GT(pairs.pair_count(), 10000u);
}

TYPED_TEST(BroadphaseMatchesOracle, HugeDomainWithDenseCluster) {
  Particles p = random_box(10000, Vec3::Constant(-5e5), Vec3::Constant(5e5), 0.5, 2.0, 10);
  const Vec3 corner(3e5, -4e5, 1e5);
  p.append(random_box(10000, corner, corner + Vec3::Constant(60.0), 0.5, 2.0, 11));
  const auto pairs = this->expect_matches_oracle(p, 0.2);
  EXPECT_GT(pairs.pair_count(), 10000u);
}

TYPED_TEST(BroadphaseMatchesOracle, ExtremeFiniteCoordinates) {
  // Far beyond any cell index an int64 could hold for the natural cell size: must neither overflow nor
  // lose pairs, however slow.
  Particles p;
  for (int k = 0; k < 100; ++k) p.add(Vec3(1e18 + 256.0 * k, -1e18, 1e18), 200.0);  // ulp(1e18) = 128
  for (int k = 0; k < 20; ++k) p.add(Vec3(-1e300, 1e300 + 1e285 * k, 0.0), 1e150);  // reach^2 finite
  p.add(Vec3(DBL_MAX, -DBL_MAX, DBL_MAX), 1.0);
  p.add(Vec3(DBL_MAX, -DBL_MAX, DBL_MAX), 1.0);  // coincident at the edge of the doubles
  p.add(Vec3(-DBL_MAX, DBL_MAX, 0.0), 1.0);
  p.add(Vec3(DBL_MIN, -DBL_MIN, 4.9e-324), 0.0);
  p.add(Vec3::Zero(), 0.0);
  this->expect_matches_oracle(p, 0.0);
  // The far cluster alone: the cell size is set by the coordinates' precision, not by the radii.
  Particles far;
  for (int k = 0; k < 300; ++k) far.add(Vec3(1e18 + 128.0 * (k % 37), -1e18 + 128.0 * (k / 37), 1e18), 150.0);
  const auto pairs = this->expect_matches_oracle(far, 1.0);
  EXPECT_GT(pairs.pair_count(), 300u);
}

TYPED_TEST(BroadphaseMatchesOracle, TouchingLatticesFarFromTheOrigin) {
  // Near 2^50 m a coordinate's ulp is a quarter metre and x / cell_size is rounded to a quarter cell;
  // touching neighbours, exactly at the reach, must still be found. Random bases sample the phase.
  std::mt19937_64 rng(16);
  std::uniform_int_distribution<std::int64_t> base(std::int64_t{1} << 50, std::int64_t{1} << 51);
  Particles p;
  for (int lattice = 0; lattice < 20; ++lattice) {
    const Vec3 corner(static_cast<double>(base(rng)), static_cast<double>(base(rng)), static_cast<double>(base(rng)));
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) {
        for (int k = 0; k < 4; ++k) p.add(corner + Vec3(i, j, k), 0.5);  // integers: exact
      }
    }
  }
  const auto pairs = this->expect_matches_oracle(p, 0.0);
  EXPECT_EQ(pairs.pair_count(), 20u * 3u * 3u * 16u);  // face neighbours, at exactly the reach
}

TYPED_TEST(BroadphaseMatchesOracle, SameResultWithOneAndTwoThreads) {
  const std::size_t n = 20000;
  const double side = cube_side(n, 0.3, 0.35);
  const Particles p = random_box(n, Vec3::Constant(-side), Vec3::Constant(0.0), 0.1, 0.5, 12);
  CandidatePairs result[2];
  for (int t = 0; t < 2; ++t) {
    TaskArena arena(t + 1);
    arena.execute([&] {
      EXPECT_EQ(TaskArena::current_concurrency(), t + 1);  // the concurrency we asked for
      TypeParam broadphase;
      broadphase.find_pairs(p.position, p.radius, 0.05, result[t]);
    });
  }
  EXPECT_TRUE(same_pairs(result[0], result[1]));
  EXPECT_TRUE(same_pairs(result[1], oracle(p, 0.05)));
}

TYPED_TEST(BroadphaseMatchesOracle, ReusedObjectGivesIdenticalResults) {
  const Particles big = random_box(10000, Vec3::Zero(), Vec3::Constant(25.0), 0.2, 0.6, 13);
  const Particles small = random_box(300, Vec3::Constant(-1.0), Vec3::Constant(2.0), 0.05, 0.2, 14);
  TypeParam broadphase;
  CandidatePairs first, again, other, empty;
  broadphase.find_pairs(big.position, big.radius, 0.1, first);
  broadphase.find_pairs(big.position, big.radius, 0.1, again);
  EXPECT_TRUE(same_pairs(again, first));
  broadphase.find_pairs(small.position, small.radius, 0.02, other);  // shrink, then grow again
  EXPECT_TRUE(same_pairs(other, oracle(small, 0.02)));
  broadphase.find_pairs({}, {}, 0.1, empty);
  EXPECT_TRUE(is_valid(empty, 0));
  broadphase.find_pairs(big.position, big.radius, 0.1, again);  // `again` holds stale content
  EXPECT_TRUE(same_pairs(again, first));
  EXPECT_TRUE(same_pairs(first, oracle(big, 0.1)));
}

TEST(GridBroadphase, AllocatesNothingAfterWarmUp) {
  if (!DEM_COUNTS_ALLOCATIONS) GTEST_SKIP() << "the sanitizer runtime owns operator new";
  const Particles p = random_box(30000, Vec3::Zero(), Vec3::Constant(30.0), 0.2, 0.5, 15);
  GridBroadphase grid;
  CandidatePairs pairs;
  TaskArena arena(2);
  arena.execute([&] {
    grid.find_pairs(p.position, p.radius, 0.1, pairs);
    const std::size_t held = grid.memory_bytes();
    const long before = allocation_count.load();
    grid.find_pairs(p.position, p.radius, 0.1, pairs);
    EXPECT_EQ(allocation_count.load() - before, 0);
    EXPECT_EQ(grid.memory_bytes(), held);
    EXPECT_GE(held, p.size() * (sizeof(Vec3) + sizeof(double)));  // at least the slot copies
  });
}

TEST(GridBroadphase, BucketTableIsAPowerOfTwoOfAtLeastTwiceTheParticles) {
  GridBroadphase grid;
  CandidatePairs pairs;
  for (std::size_t n : {1u, 2u, 3u, 1000u, 1025u}) {
    const Particles p = random_box(n, Vec3::Zero(), Vec3::Constant(5.0), 0.1, 0.2, n);
    grid.find_pairs(p.position, p.radius, 0.0, pairs);
    EXPECT_GE(grid.bucket_count(), 2 * n);
    EXPECT_EQ(grid.bucket_count() & (grid.bucket_count() - 1), 0u);
    EXPECT_GE(grid.cell_size(), 2 * *std::max_element(p.radius.begin(), p.radius.end()));
  }
}

TEST(BruteForceBroadphase, FindsExactlyThePairsWithinReach) {
  Particles p;
  p.add(Vec3(0.0, 0.0, 0.0), 0.5);
  p.add(Vec3(1.0, 0.0, 0.0), 0.5);  // 1.0 from the first: within 0.5 + 0.5 + 0.1
  p.add(Vec3(2.5, 0.0, 0.0), 0.5);  // 1.5 from the second: beyond
  p.add(Vec3(1.0, 1.1, 0.0), 0.5);  // exactly at the reach of the second: included
  const CandidatePairs pairs = oracle(p, 0.1);
  EXPECT_EQ(pairs.row_start, (std::vector<std::uint32_t>{0, 1, 2, 2, 2}));
  EXPECT_EQ(pairs.partner, (std::vector<std::uint32_t>{1, 3}));
}

TEST(CandidatePairs, IsValidRejectsBrokenInvariants) {
  CandidatePairs good;
  good.row_start = {0, 2, 3, 3};
  good.partner = {1, 2, 2};
  EXPECT_TRUE(is_valid(good, 3));
  EXPECT_FALSE(is_valid(good, 4));  // wrong row count
  CandidatePairs bad = good;
  bad.partner = {2, 1, 2};  // row not ascending
  EXPECT_FALSE(is_valid(bad, 3));
  bad.partner = {1, 1, 2};  // duplicate
  EXPECT_FALSE(is_valid(bad, 3));
  bad.partner = {1, 2, 1};  // j <= i
  EXPECT_FALSE(is_valid(bad, 3));
  bad.partner = {1, 2, 3};  // j >= n
  EXPECT_FALSE(is_valid(bad, 3));
  bad = good;
  bad.row_start = {0, 2, 3, 2};  // decreasing, last offset != pair count
  EXPECT_FALSE(is_valid(bad, 3));
  bad.row_start = {1, 2, 3, 3};  // does not start at 0
  EXPECT_FALSE(is_valid(bad, 3));
  EXPECT_TRUE(is_valid(CandidatePairs{}, 0));
}

// Skin: dyadic coordinates and displacements, so the displacement is exact and the boundary is sharp.
std::vector<Vec3> skin_positions() {
  std::vector<Vec3> x;
  for (int i = 0; i < 5000; ++i) x.emplace_back(0.25 * (i % 17), -0.5 * (i % 13), 2.0 * i);
  return x;
}

TEST(SkinTracker, ExactlyHalfTheSkinNeedsNoRebuild) {
  SkinTracker tracker;
  auto x = skin_positions();
  tracker.reset(x);
  EXPECT_FALSE(tracker.needs_rebuild(x, 1.0));
  EXPECT_EQ(tracker.max_displacement(x), 0.0);
  x[4321].x() += 0.5;
  EXPECT_EQ(tracker.max_displacement(x), 0.5);
  EXPECT_FALSE(tracker.needs_rebuild(x, 1.0));
  x[17] += Vec3(3.0, 4.0, 0.0);  // |d| = 5 = skin / 2 with skin 10, off axis
  EXPECT_EQ(tracker.max_displacement(x), 5.0);
  EXPECT_FALSE(tracker.needs_rebuild(x, 10.0));
}

TEST(SkinTracker, JustAboveHalfTheSkinNeedsRebuild) {
  SkinTracker tracker;
  auto x = skin_positions();
  tracker.reset(x);
  x[2600].y() += std::nextafter(0.5, 1.0);  // y was 0, so the step is exact
  EXPECT_TRUE(tracker.needs_rebuild(x, 1.0));
  tracker.reset(x);  // a rebuild resets the reference
  EXPECT_FALSE(tracker.needs_rebuild(x, 1.0));
}

TEST(SkinTracker, ChangedCountOrNoResetOrNaNNeedsRebuild) {
  SkinTracker tracker;
  auto x = skin_positions();
  EXPECT_TRUE(tracker.needs_rebuild(x, 1.0));  // never reset
  tracker.reset(x);
  x.pop_back();
  EXPECT_TRUE(tracker.needs_rebuild(x, 1.0));
  EXPECT_EQ(tracker.max_displacement(x), std::numeric_limits<double>::infinity());
  x.emplace_back(Vec3::Zero());
  x.emplace_back(Vec3::Zero());
  EXPECT_TRUE(tracker.needs_rebuild(x, 1.0));
  x = skin_positions();
  x[10].z() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(tracker.needs_rebuild(x, 1.0));
  tracker.reset({});
  EXPECT_FALSE(tracker.needs_rebuild({}, 0.0));  // empty is a valid state
}

}  // namespace
}  // namespace dem::broadphase

// Long validation of step doubling (ctest label `long`): the undamped dense packings of
// doubling_test.cpp over 1e5 sync intervals (PHYSICS.md 6.6 measure: |dE| against the initial kinetic +
// elastic energy, no gravity, zero total momentum), at tolerances 1e-2 and 1e-3, with the same
// ensemble measure of a trend as the short test.
#include <gtest/gtest.h>

#include <cmath>

#include "tests/contact_scenes.h"
#include "tests/doubling_scenes.h"

namespace dem {
namespace {

using namespace dem::test;

void expect_bounded_without_trend(const PackingEnsemble& e) {
  EXPECT_LE(e.max_error, 1e-3);
  EXPECT_LE(std::abs(e.end_mean), 3 * e.end_standard_error);
  EXPECT_LE(e.rms.back(), 1.5 * std::sqrt(5.0) * e.rms[1]);  // drift 5, random walk 2.2 (see doubling_test)
}

TEST(DoublingLong, UndampedPackingEnergyErrorIsBoundedWithoutTrendOver1e5IntervalsAtTolerance1e2) {
  expect_bounded_without_trend(packing_ensemble(1e-2, 100'000, 8));
}

TEST(DoublingLong, UndampedPackingEnergyErrorIsBoundedWithoutTrendOver1e5IntervalsAtTolerance1e3) {
  expect_bounded_without_trend(packing_ensemble(1e-3, 100'000, 8));
}

}  // namespace
}  // namespace dem

// Step-doubling control (docs/physics.md 6.4, 6.6): the error norm against hand-computed cases and its scaling
// with the step, the level decisions (reject and drop, accept, promote only when aligned, forced
// accept at level_min), and Richardson extrapolation raising the order on a known series.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "engine/step_control.h"

namespace dem {
namespace {

TEST(StepControl, ErrorNormFollowsTheReconstructedSeedFormula) {
  const TrialState one{Vec3(1, 0, 0), Vec3(0, 2, 0), Vec3(0, 0, 3)};
  const TrialState two{Vec3(1, 0.003, 0.004), Vec3(0, 2.1, 0), Vec3(0, 0, 3.2)};
  // Reference time T = the step (the seed's weighting): |dx| = 0.005; w dt |dv| = 1 * 0.01 * 0.1;
  // w R dt |dw| = 1 * 0.5 * 0.01 * 0.2; denominator 0.3 + 1e-3 * 0.5; less the round-off allowance
  // 16 eps (|x2| + w dt |v2| + w R dt |w2|).
  const Real noise = 16 * std::numeric_limits<Real>::epsilon() * (std::sqrt(1 + 0.003 * 0.003 + 0.004 * 0.004) + 0.021 + 0.016);
  const Real expected = (0.005 + 0.001 + 0.001 - noise) / (0.3 + 0.0005);
  EXPECT_NEAR(step_error(one, two, Vec3(0.3, 0, 0), 0.01, 0.01, 0.5, 1, 1e-3), expected, 1e-15);
  // A particle at rest is measured against the floor dx_min R, never divided by zero.
  EXPECT_TRUE(std::isfinite(step_error(one, one, Vec3::Zero(), 0.01, 0.01, 0.5, 1, 1e-3)));
  EXPECT_EQ(step_error(one, one, Vec3::Zero(), 0.01, 0.01, 0.5, 1, 1e-3), 0.0);
  // NaN in a trial gives NaN (the step is rejected).
  const TrialState broken{Vec3(1, std::nan(""), 0), Vec3::Zero(), Vec3::Zero()};
  EXPECT_TRUE(std::isnan(step_error(one, broken, Vec3(0.3, 0, 0), 0.01, 0.01, 0.5, 1, 1e-3)));
}

TEST(StepControl, FixedReferenceTimeWeighsVelocityErrorsByItAndScalesTheFloorWithTheStep) {
  const TrialState one{Vec3(1, 0, 0), Vec3(0, 2, 0), Vec3::Zero()};
  const TrialState two{Vec3(1, 0.003, 0.004), Vec3(0, 2.1, 0), Vec3::Zero()};
  // T = 0.1 s, h = 0.01 s: w T |dv| = 0.01; floor dx_min R h / T = 1e-3 * 0.5 * 0.1.
  const Real noise = 16 * std::numeric_limits<Real>::epsilon() * (std::sqrt(1 + 0.003 * 0.003 + 0.004 * 0.004) + 0.21);
  EXPECT_NEAR(step_error(one, two, Vec3(0.3, 0, 0), 0.01, 0.1, 0.5, 1, 1e-3), (0.005 + 0.01 - noise) / (0.3 + 0.00005),
              1e-15);
  // Error per unit step: the same local error per unit of step and of displacement gives the same E
  // at any step, down to a particle at rest.
  const TrialState slow{Vec3(1, 1e-9, 0), Vec3::Zero(), Vec3::Zero()};
  const TrialState at_rest{Vec3(1, 0, 0), Vec3::Zero(), Vec3::Zero()};
  const Real e1 = step_error(slow, at_rest, Vec3::Zero(), 1e-3, 0.1, 0.5, 1, 1e-3);
  const TrialState slower{Vec3(1, 0.5e-9, 0), Vec3::Zero(), Vec3::Zero()};
  const Real e2 = step_error(slower, at_rest, Vec3::Zero(), 0.5e-3, 0.1, 0.5, 1, 1e-3);
  EXPECT_NEAR(e2 / e1, 1.0, 1e-5);
}

TEST(StepControl, DifferencesWithinRoundOffOfTheStateAreNoError) {
  const TrialState one{Vec3(20, 0, 0), Vec3(1, 0, 0), Vec3::Zero()};
  TrialState two = one;
  two.position.x() = std::nextafter(20.0, 21.0);
  two.velocity.x() = std::nextafter(1.0, 2.0);
  EXPECT_EQ(step_error(one, two, Vec3::Zero(), 1e-6, 0.1, 0.5, 1, 1e-3), 0.0);
  two.position.x() = 20 + 1e-12;  // far above round-off: an error
  EXPECT_GT(step_error(one, two, Vec3::Zero(), 1e-6, 0.1, 0.5, 1, 1e-3), 0.0);
}

TEST(StepControl, ErrorOfVerletOnAnOscillatorScalesAsTheStepToTheOrder) {
  // x'' = -x with velocity Verlet: one step of h against two of h/2; the position difference is
  // O(h^3) and the displacement O(h), so E ~ h^2 = h^p for p = 2 (docs/physics.md 6.4).
  auto verlet = [](Real x, Real v, Real h) {
    v += 0.5 * h * -x;
    x += h * v;
    v += 0.5 * h * -x;
    return TrialState{Vec3(x, 0, 0), Vec3(v, 0, 0), Vec3::Zero()};
  };
  auto error = [&](Real h) {
    const TrialState one = verlet(1, 0.3, h);
    const TrialState half = verlet(1, 0.3, 0.5 * h);
    const TrialState two = verlet(half.position.x(), half.velocity.x(), 0.5 * h);
    return step_error(one, two, Vec3(two.position.x() - 1, 0, 0), h, h, 1, 0, 1e-12);
  };
  const Real slope = std::log2(error(0.02) / error(0.01));
  EXPECT_NEAR(slope, 2.0, 0.05);
}

TEST(StepControl, LevelDecisions) {
  // Reject: error 100 tol with p = 2, S = 0.8: drop ceil(log2(125)/2) = 4 levels.
  LevelDecision d = decide_level(100e-4, 3, -10, 10, 2, 0.8, 1e-4, true);
  EXPECT_FALSE(d.accept);
  EXPECT_EQ(d.level, -1);
  // A rejection never drops below level_min; at level_min the step is accepted and counted forced.
  d = decide_level(1e6, -9, -10, 10, 2, 0.8, 1e-4, true);
  EXPECT_EQ(d.level, -10);
  d = decide_level(1e6, -10, -10, 10, 2, 0.8, 1e-4, true);
  EXPECT_TRUE(d.accept);
  EXPECT_TRUE(d.forced);
  // NaN errors reject (never accept a broken trial above level_min).
  EXPECT_FALSE(decide_level(std::nan(""), 0, -10, 10, 2, 0.8, 1e-4, true).accept);
  // Accept and stay: error within tolerance but not 2^p below S tol.
  d = decide_level(0.5e-4, 0, -10, 10, 2, 0.8, 1e-4, true);
  EXPECT_TRUE(d.accept);
  EXPECT_EQ(d.level, 0);
  // Accept and promote one level, only at an aligned tick, never past level_max.
  EXPECT_EQ(decide_level(0.1e-4, 0, -10, 10, 2, 0.8, 1e-4, true).level, 1);
  EXPECT_EQ(decide_level(0.1e-4, 0, -10, 10, 2, 0.8, 1e-4, false).level, 0);
  EXPECT_EQ(decide_level(0.1e-4, 10, -10, 10, 2, 0.8, 1e-4, true).level, 10);
}

TEST(StepControl, RichardsonRaisesTheOrder) {
  // y(h) = y* + c h^p + d h^(p+1): the combination of y(h) and y(h/2) cancels the h^p term.
  const Real exact = 2.0, c = 3.0, d = 5.0;
  for (int p : {1, 2}) {
    auto y = [&](Real h) { return exact + c * std::pow(h, p) + d * std::pow(h, p + 1); };
    const Real h = 0.01;
    const Vec3 improved = richardson(Vec3(y(h), 0, 0), Vec3(y(h / 2), 0, 0), p);
    EXPECT_LT(std::abs(improved.x() - exact), 2 * d * std::pow(h, p + 1));
    EXPECT_GT(std::abs(y(h / 2) - exact), 10 * std::abs(improved.x() - exact));
  }
}

}  // namespace
}  // namespace dem

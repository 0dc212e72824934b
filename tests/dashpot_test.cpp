// The velocity that velocity Verlet's dashpots see (integrator.predicted_dashpot; engine/forces.h,
// DashpotVelocity), on a lasting damped contact whose motion is known in closed form: a ball
// resting under gravity on a plane, or on an immovable ball, released from rest off its equilibrium
// overlap by less than that overlap, so the contact never opens and the overlap is a damped
// harmonic oscillator about m g / k.
//  1. Order: with the half-step velocity the dashpot lags by h/2 and the error is first order in h;
//     with the predicted velocity it is second order (least-squares order over steps spanning 16x).
//  2. Stability: the predicted dashpot's limit is omega0 h = 2 (sqrt(1 + 4 zeta^2) - 2 zeta), the
//     half-step one's 2 (sqrt(1 + zeta^2) - zeta) (docs/physics.md 4.2): bounded just below, growing just
//     above, for each.
// The oracle is the damped oscillator's solution, derived here; nothing is taken from the engine.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

#include "engine/config.h"
#include "engine/world.h"
#include "tests/contact_scenes.h"

namespace dem {
namespace {

using namespace dem::test;

constexpr Real radius = 0.01, mass = 0.01, stiffness = 1e4, g = 9.81;
const Real omega0 = std::sqrt(stiffness / mass);  // 1000 1/s; m* = m against a wall or an immovable ball
const Real rest_overlap = mass * g / stiffness;   // 9.81e-6 m
const Real amplitude = 0.5 * rest_overlap;        // released below the rest overlap: never leaves

enum class Support { wall, ball };

// Ball released from rest at overlap rest_overlap + amplitude, fixed step h, damping ratio zeta.
WorldConfig resting_ball(Support support, Real zeta, Real h, bool predicted) {
  WorldConfig c = base_config(h);
  c.model.gravity = Vec3(0, 0, -g);
  c.model.separation = Separation::overlap;
  c.contacts[0].normal_stiffness = stiffness;
  c.contacts[0].normal_damping = {DampingKind::coefficient, 2 * zeta * std::sqrt(stiffness * mass)};
  c.integrator.predicted_dashpot = predicted;
  const Real overlap = rest_overlap + amplitude;
  if (support == Support::wall) {
    c.walls.push_back(plane(Vec3::Zero(), Vec3::UnitZ()));
    c.particles.push_back(particle(Vec3(0, 0, radius - overlap), Vec3::Zero(), radius, mass));
  } else {
    c.particles.push_back(particle(Vec3::Zero(), Vec3::Zero(), radius, std::numeric_limits<Real>::infinity()));
    c.particles.push_back(particle(Vec3(0, 0, 2 * radius - overlap), Vec3::Zero(), radius, mass));
  }
  return c;
}

// y(t) = overlap - rest overlap for y(0) = amplitude, y'(0) = 0 (underdamped).
Real oracle_offset(Real zeta, Real t) {
  const Real wd = omega0 * std::sqrt(1 - zeta * zeta);
  return amplitude * std::exp(-zeta * omega0 * t) * (std::cos(wd * t) + zeta * omega0 / wd * std::sin(wd * t));
}

Real ball_height(const World& world) {
  const State& s = world.state();
  for (std::size_t q = 0; q < s.size(); ++q)
    if (s.inv_mass[q] > 0) return s.position[q].z();
  return 0;
}

Real offset_of(const World& world, Support support) {
  const Real touching_height = support == Support::wall ? radius : 2 * radius;
  return touching_height - ball_height(world) - rest_overlap;
}

// Largest |y - oracle| / amplitude over 10 ms (1.6 periods), at every step.
Real max_error(Support support, Real zeta, Real h, bool predicted) {
  World world(resting_ball(support, zeta, h, predicted));
  const long steps = std::lround(0.01 / h);
  Real worst = 0;
  for (long n = 1; n <= steps; ++n) {
    EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    worst = std::max(worst, std::abs(offset_of(world, support) - oracle_offset(zeta, n * h)) / amplitude);
  }
  return worst;
}

// Least-squares slope of log error against log h over omega0 h = 0.02 .. 0.32.
Real fitted_order(Support support, Real zeta, bool predicted, std::vector<Real>& errors) {
  Real sx = 0, sy = 0, sxx = 0, sxy = 0;
  const int points = 5;
  for (int k = 0; k < points; ++k) {
    const Real h = 0.02 * std::ldexp(1.0, k) / omega0;
    const Real e = max_error(support, zeta, h, predicted);
    errors.push_back(e);
    const Real x = std::log(h), y = std::log(e);
    sx += x, sy += y, sxx += x * x, sxy += x * y;
  }
  return (points * sxy - sx * sy) / (points * sxx - sx * sx);
}

void expect_orders(Support support) {
  const Real zeta = 0.2;
  std::vector<Real> lagging, predicted;
  const Real order_lagging = fitted_order(support, zeta, false, lagging);
  const Real order_predicted = fitted_order(support, zeta, true, predicted);
  std::printf("%s, zeta %.1f: order %.2f (half-step velocity), %.2f (predicted); relative errors at omega0 h = "
              "0.02: %.2e and %.2e\n",
              support == Support::wall ? "wall" : "ball", zeta, order_lagging, order_predicted, lagging[0],
              predicted[0]);
  EXPECT_NEAR(order_lagging, 1.0, 0.25);
  EXPECT_NEAR(order_predicted, 2.0, 0.25);
  for (std::size_t k = 0; k < lagging.size(); ++k) EXPECT_LT(predicted[k], lagging[k]) << "step " << k;
  ::testing::Test::RecordProperty("order_half_step", sci(order_lagging));
  ::testing::Test::RecordProperty("order_predicted", sci(order_predicted));
}

TEST(Dashpot, PredictedVelocityMakesAWallContactSecondOrder) { expect_orders(Support::wall); }

TEST(Dashpot, PredictedVelocityMakesAPairContactSecondOrder) { expect_orders(Support::ball); }

// Largest |y| / amplitude over 400 steps of h = factor x the limit.
Real largest_offset(Real zeta, bool predicted, Real factor) {
  const Real z = predicted ? 2 * zeta : zeta;
  const Real limit = 2 * (std::sqrt(1 + z * z) - z) / omega0;
  World world(resting_ball(Support::wall, zeta, factor * limit, predicted));
  Real worst = 0;
  for (int n = 0; n < 400; ++n) {
    EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    worst = std::max(worst, std::abs(offset_of(world, Support::wall)) / amplitude);
  }
  return worst;
}

TEST(Dashpot, StabilityLimitsOfBothVelocities) {
  for (const bool predicted : {false, true}) {
    for (const Real zeta : {0.2, 0.5}) {
      SCOPED_TRACE(::testing::Message() << (predicted ? "predicted" : "half-step") << " zeta " << zeta);
      EXPECT_LE(largest_offset(zeta, predicted, 0.97), 1.0 + 1e-9);
      EXPECT_GT(largest_offset(zeta, predicted, 1.03), 1.0);
    }
  }
}

}  // namespace
}  // namespace dem

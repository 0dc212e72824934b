// Prism walls (lifter bars) against an independent shape with the same surface: a prism of square
// cross-section is a solid box, so both must give the same contact everywhere; and the start-up ramp
// against its closed form, for each wall whether or not it turns as its neighbour in the list does.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "engine/walls.h"

namespace dem {
namespace {

MaterialTable one_material() { return MaterialTable({MaterialConfig{}}, {ContactConfig{}}, Separation::force_zero); }

WallConfig square_prism(const Vec3& half) {
  WallConfig w;
  w.kind = WallKind::prism;
  w.point = Vec3(0.3, -0.2, 0.1);
  w.axis = Vec3::UnitZ();
  w.length = 2 * half.z();
  // Corners given clockwise on purpose: the wall orders them itself.
  for (const auto& [x, y] : {std::pair{-1, -1}, {-1, 1}, {1, 1}, {1, -1}})
    w.profile.push_back(w.point + Vec3(x * half.x(), y * half.y(), 0));
  return w;
}

TEST(PrismWall, SquarePrismTouchesLikeASolidBox) {
  const Vec3 half(0.2, 0.1, 0.3);
  WallConfig box;
  box.kind = WallKind::box;
  box.inside = false;
  box.point = Vec3(0.3, -0.2, 0.1);
  box.half_extents = half;
  const Vec3 spin(0.4, -1.0, 2.0);
  box.angular_velocity = spin;
  WallConfig prism = square_prism(half);
  prism.angular_velocity = spin;
  const MaterialTable materials = one_material();
  Walls walls({box, prism}, materials);
  walls.set_time(0.37);  // both turned by the same rotation
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<Real> u(-0.6, 0.6);
  int touching = 0, inside = 0;
  for (int k = 0; k < 20000; ++k) {
    const Vec3 x = walls.point(0) + Vec3(u(rng), u(rng), u(rng));
    const Real r = 0.05 + 0.1 * std::abs(u(rng));
    WallTouch a, b;
    const bool ta = walls.touch(0, 0, x, r, a), tb = walls.touch(1, 0, x, r, b);
    ASSERT_EQ(ta, tb) << "at " << x.transpose();
    if (!ta) continue;
    ++touching;
    inside += a.overlap > r;
    EXPECT_NEAR(a.overlap, b.overlap, 1e-12);
    EXPECT_LT((a.normal - b.normal).norm(), 1e-9) << "at " << x.transpose();
  }
  EXPECT_GT(touching, 1000);
  EXPECT_GT(inside, 100);  // centres inside the solid are pushed out through the nearest face
}

TEST(PrismWall, EdgeContactPointsFromTheEdge) {
  // A triangle cross-section: a sphere off the apex touches the apex edge along the bisector.
  WallConfig w;
  w.kind = WallKind::prism;
  w.axis = Vec3::UnitZ();
  w.profile = {Vec3(-1, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0)};
  Walls walls({w}, one_material());
  WallTouch t;
  ASSERT_TRUE(walls.touch(0, 0, Vec3(0, 1.5, 7), 0.6, t));
  EXPECT_NEAR(t.overlap, 0.1, 1e-14);
  EXPECT_NEAR((t.normal - Vec3::UnitY()).norm(), 0, 1e-14);
  EXPECT_FALSE(walls.touch(0, 0, Vec3(0, 1.5, 7), 0.4, t));
  // Beside the face through (1, 0) and (0, 1): its outward normal.
  const Vec3 n = Vec3(1, 1, 0).normalized();
  ASSERT_TRUE(walls.touch(0, 0, Vec3(0.5, 0.5, 0) + 0.3 * n, 0.4, t));
  EXPECT_NEAR(t.overlap, 0.1, 1e-14);
  EXPECT_NEAR((t.normal - n).norm(), 0, 1e-14);
}

TEST(PrismWall, RejectsProfilesThatAreNotConvexPolygons) {
  WallConfig w;
  w.kind = WallKind::prism;
  w.profile = {Vec3(0, 0, 0), Vec3(1, 0, 0)};
  EXPECT_THROW(Walls::check_prism(w), std::invalid_argument);
  w.profile = {Vec3(0, 0, 0), Vec3(2, 0, 0), Vec3(1, 0.2, 0), Vec3(2, 2, 0), Vec3(0, 2, 0)};  // dented
  EXPECT_THROW(Walls::check_prism(w), std::invalid_argument);
  w.profile = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(2, 0, 0)};  // no area
  EXPECT_THROW(Walls::check_prism(w), std::invalid_argument);
  // A pentagram turns left at every corner and encloses area, but crosses itself.
  w.profile.clear();
  for (int k : {0, 2, 4, 1, 3}) w.profile.push_back(Vec3(std::cos(2 * pi * k / 5), std::sin(2 * pi * k / 5), 0));
  EXPECT_THROW(Walls::check_prism(w), std::invalid_argument);
}

TEST(WallRamp, AngleAndSpeedFollowTheLinearStartUp) {
  WallConfig w;
  w.kind = WallKind::cylinder;
  w.radius = 1;
  w.angular_velocity = Vec3(0, 0, 3);
  w.ramp_time = 2;
  Walls walls({w}, one_material());
  for (const Real t : {0.0, 0.5, 1.999, 2.0, 3.5}) {
    walls.set_time(t);
    const Real angle = t < 2 ? 3 * t * t / 4 : 3 * (t - 1);
    const Real speed = t < 2 ? 3 * t / 2 : 3;
    const Eigen::Matrix3d expected = Eigen::AngleAxisd(angle, Vec3::UnitZ()).toRotationMatrix();
    EXPECT_LT((walls.rotation(0) - expected).norm(), 1e-14) << "t = " << t;
    EXPECT_NEAR(walls.angular_velocity(0).z(), speed, 1e-15);
    EXPECT_NEAR((walls.velocity_at(0, Vec3(1, 0, 0)) - Vec3(0, speed, 0)).norm(), 0, 1e-15);
  }
}

TEST(WallRamp, EachWallTurnsByItsOwnSpinAndRampWhereNeighboursShareOrDiffer) {
  // Neighbours in the list that share spin and ramp, then differ in the ramp only, then in the spin
  // only, then do not turn: each rotation against its closed form.
  struct Motion {
    Vec3 spin;
    Real ramp;
  };
  const std::vector<Motion> motions{{Vec3(0, 0, 3), 2}, {Vec3(0, 0, 3), 2}, {Vec3(0, 0, 3), 0.5},
                                    {Vec3(1, -2, 0.5), 0.5}, {Vec3(0, 0, 0), 0.5}, {Vec3(1, -2, 0.5), 0.5}};
  std::vector<WallConfig> configs;
  for (const Motion& m : motions) {
    WallConfig w;
    w.kind = WallKind::cylinder;
    w.radius = 1;
    w.angular_velocity = m.spin;
    w.ramp_time = m.ramp;
    configs.push_back(w);
  }
  Walls walls(configs, one_material());
  for (const Real t : {0.0, 0.3, 1.0, 2.5}) {
    walls.set_time(t);
    for (std::size_t k = 0; k < motions.size(); ++k) {
      const Real ramp = motions[k].ramp, rate = motions[k].spin.norm();
      const Real angle = rate * (t < ramp ? t * t / (2 * ramp) : t - ramp / 2);
      const Eigen::Matrix3d expected =
          rate > 0 ? Eigen::AngleAxisd(angle, motions[k].spin.normalized()).toRotationMatrix()
                   : Eigen::Matrix3d(Eigen::Matrix3d::Identity());
      EXPECT_LT((walls.rotation(k) - expected).norm(), 1e-14) << "wall " << k << ", t = " << t;
    }
  }
}

}  // namespace
}  // namespace dem

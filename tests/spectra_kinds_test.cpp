// Collision spectra per kind of size classes (docs/physics.md 7.4, mill.size_classes): a scene with one
// collision of each kind books each in its kind with the impact energy m* v_n^2 / 2 the test computes;
// the classes' shares of the dissipation add up to 1 and are the spectra's per-kind totals, a mixed
// contact half to each class; a mill with fines books the same spectra on 1 and 3 threads, under a
// fixed step and under step doubling with a level per particle, and across a checkpoint.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <unistd.h>
#include <vector>

#include "engine/scene_loader.h"
#include "engine/world.h"
#include "tests/thread_support.h"

namespace dem {
namespace {

using S = CollisionSpectra;

constexpr Real fine_radius = 0.0005, ball_radius = 0.004;
constexpr Real fine_mass = 4e-6, ball_mass = 2e-3;  // [kg]
constexpr Real restitution = 0.5;

TEST(SpectraKinds, KindsNameEachPairOfClassesAndEachClassWithTheLiner) {
  const S one;
  EXPECT_EQ(one.kind_count(), 2);
  EXPECT_EQ(one.kind_name(S::ball_ball), "ball-ball");
  EXPECT_EQ(one.kind_name(S::ball_wall), "ball-liner");
  const S three({0.001, 0.002});
  ASSERT_EQ(three.class_count(), 3);
  ASSERT_EQ(three.kind_count(), 9);
  const std::vector<std::string> names = {"c0-c0", "c0-c1", "c0-c2", "c1-c1", "c1-c2",
                                          "c2-c2", "c0-liner", "c1-liner", "c2-liner"};
  for (S::Kind k = 0; k < three.kind_count(); ++k) EXPECT_EQ(three.kind_name(k), names[static_cast<std::size_t>(k)]);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      const S::Kind k = three.pair_kind(a, b);
      EXPECT_EQ(k, three.pair_kind(b, a));
      EXPECT_EQ(three.classes_of(k)[0], std::min(a, b));
      EXPECT_EQ(three.classes_of(k)[1], std::max(a, b));
    }
  // Edges belong to the class above them.
  EXPECT_EQ(three.class_of_radius(0.0005), 0);
  EXPECT_EQ(three.class_of_radius(0.001), 1);
  EXPECT_EQ(three.class_of_radius(0.0015), 1);
  EXPECT_EQ(three.class_of_radius(0.002), 2);
}

ParticleConfig particle(Real radius, Real mass, Vec3 x, Vec3 v) {
  ParticleConfig p;
  p.radius = radius;
  p.mass = mass;
  p.position = x;
  p.velocity = v;
  return p;
}

/// m* of a pair (a wall: the particle's mass).
Real reduced(Real a, Real b) { return a * b / (a + b); }

/// Five head-on collisions far apart, without gravity, above a floor z = 0: fine-fine, fine-ball,
/// ball-ball (pairs along x at z = 0.05) and a fine and a ball falling onto the floor.
struct Oracle {
  WorldConfig config;
  // Per kind of the two-class spectra: the impact energy [J].
  std::vector<double> impact;
  Oracle() {
    config.contacts[0].normal_stiffness = 1e4;
    config.contacts[0].normal_damping = {DampingKind::restitution, restitution};
    WallConfig floor;
    floor.kind = WallKind::plane;
    config.walls.push_back(floor);
    const Real z = 0.05, gap = 1e-5;
    const S spectra({0.002});
    impact.assign(static_cast<std::size_t>(spectra.kind_count()), 0);
    // Pairs: the left one moves at +u, the right one rests, a gap apart.
    const auto pair = [&](Real x, Real ra, Real ma, Real rb, Real mb, Real u) {
      config.particles.push_back(particle(ra, ma, Vec3(x, 0, z), Vec3(u, 0, 0)));
      config.particles.push_back(particle(rb, mb, Vec3(x + ra + rb + gap, 0, z), Vec3::Zero()));
      impact[static_cast<std::size_t>(spectra.pair_kind(spectra.class_of_radius(ra), spectra.class_of_radius(rb)))] =
          0.5 * reduced(ma, mb) * u * u;
    };
    pair(-0.2, fine_radius, fine_mass, fine_radius, fine_mass, 0.5);
    pair(0.0, ball_radius, ball_mass, fine_radius, fine_mass, 0.3);
    pair(0.2, ball_radius, ball_mass, ball_radius, ball_mass, 0.4);
    // Onto the floor at -w.
    const auto drop = [&](Real x, Real r, Real m, Real w) {
      config.particles.push_back(particle(r, m, Vec3(x, 0.1, r + gap), Vec3(0, 0, -w)));
      impact[static_cast<std::size_t>(spectra.wall_kind(spectra.class_of_radius(r)))] = 0.5 * m * w * w;
    };
    drop(-0.1, fine_radius, fine_mass, 0.6);
    drop(0.1, ball_radius, ball_mass, 0.7);
    config.integrator.dt = 2.5e-7;  // t_c / 180 for two fines
    config.collision_spectra = true;
    config.spectra_size_classes = {0.002};
  }
};

void expect_oracle(const World& world, const std::vector<double>& impact) {
  ASSERT_NE(world.collision_spectra(), nullptr);
  const S& spectra = *world.collision_spectra();
  ASSERT_EQ(spectra.kind_count(), 5);
  ASSERT_EQ(world.pair_contacts().size() + world.wall_contacts().size(), 0u) << "every contact has ended";
  double kinds_dissipated = 0;
  for (S::Kind k = 0; k < spectra.kind_count(); ++k) {
    const double e = impact[static_cast<std::size_t>(k)];
    EXPECT_EQ(spectra.events(k), 1u) << spectra.kind_name(k);
    EXPECT_NEAR(spectra.total(k, S::impact), e, 2e-3 * e) << spectra.kind_name(k);
    EXPECT_NEAR(spectra.total(k, S::normal_dissipated), (1 - restitution * restitution) * e, 5e-3 * e)
        << spectra.kind_name(k);
    kinds_dissipated += spectra.dissipated(k);
  }
  EXPECT_NEAR(kinds_dissipated, world.dissipated_energy(), 1e-12 * kinds_dissipated);
  // Shares: the fines' own kinds whole, fine-ball half; they add up to 1.
  const double fines = spectra.dissipated(spectra.pair_kind(0, 0)) + spectra.dissipated(spectra.wall_kind(0)) +
                       0.5 * spectra.dissipated(spectra.pair_kind(0, 1));
  const double balls = spectra.dissipated(spectra.pair_kind(1, 1)) + spectra.dissipated(spectra.wall_kind(1)) +
                       0.5 * spectra.dissipated(spectra.pair_kind(0, 1));
  EXPECT_NEAR(spectra.dissipation_share(0), fines / kinds_dissipated, 1e-12);
  EXPECT_NEAR(spectra.dissipation_share(1), balls / kinds_dissipated, 1e-12);
  EXPECT_NEAR(spectra.dissipation_share(0) + spectra.dissipation_share(1), 1, 1e-12);
  EXPECT_GT(spectra.dissipation_share(0), 0);
}

TEST(SpectraKinds, EachCollisionLandsInItsKindWithItsImpactEnergy) {
  const Oracle oracle;
  World world(oracle.config);
  ASSERT_EQ(world.run_until(0.01), StepStatus::ok);
  expect_oracle(world, oracle.impact);
}

TEST(SpectraKinds, StepDoublingWithLevelsPerParticleBooksTheSameKinds) {
  const Oracle oracle;
  WorldConfig config = oracle.config;
  config.integrator.control = Control::doubling;
  config.integrator.particle_levels = true;
  config.integrator.dt = config.integrator.dt_base = 1e-3;
  config.integrator.level_min = -12;
  config.integrator.level_max = 0;
  config.integrator.tolerance = 1e-5;
  World world(config);
  ASSERT_EQ(world.run_until(0.01), StepStatus::ok);
  expect_oracle(world, oracle.impact);
}

TEST(SpectraKinds, OneClassKeepsBallBallAndBallLiner) {
  WorldConfig config = Oracle().config;
  config.spectra_size_classes.clear();
  World world(config);
  ASSERT_EQ(world.run_until(0.01), StepStatus::ok);
  const S& spectra = *world.collision_spectra();
  ASSERT_EQ(spectra.kind_count(), 2);
  EXPECT_EQ(spectra.events(S::ball_ball), 3u);
  EXPECT_EQ(spectra.events(S::ball_wall), 2u);
  EXPECT_EQ(spectra.dissipation_share(0), 1);
}

/// A small 2D mill with 30 balls and 20 fines, in two size classes.
std::string fines_mill() {
  return R"(
[scene]
dimension = 2
thickness = 0.008
gravity = [0, -9.81, 0]
[[contacts]]
normal_stiffness = 5e3
normal_damping = { restitution = 0.5 }
sliding_friction = 0.4
rolling_friction = 0.02
[[generators]]
count = 20
seed = 5
region = { type = "cylinder", center = [0, 0, 0], axis = [0, 0, 1], radius = 0.07 }
size = { radius = 0.0005 }
[mill]
diameter = 0.2
lifters = 8
lifter_height = 0.012
lifter_width = 0.008
lifter_face_angle = 10
critical_fraction = 0.75
ramp_time = 0.2
size_classes = [0.002]
charge = { count = 30, size = { radius = 0.004 }, seed = 3 }
[integrator]
dt = 1e-5
)";
}

std::unique_ptr<World> fines_mill_world(int threads, const std::vector<std::string>& overrides) {
  std::vector<std::string> o = overrides;
  o.push_back("run.threads=" + std::to_string(threads));
  const Scene scene = load_scene_text(fines_mill(), "mill.toml", ".", o);
  return std::make_unique<World>(scene.world);
}

void expect_same_spectra(const S& a, const S& b) {
  ASSERT_EQ(a.kind_count(), b.kind_count());
  for (S::Kind k = 0; k < a.kind_count(); ++k) {
    EXPECT_EQ(a.events(k), b.events(k)) << a.kind_name(k);
    for (int q = 0; q < S::quantity_count; ++q)
      for (int bin = 0; bin < S::bin_count; ++bin) {
        EXPECT_EQ(a.count(k, S::Quantity(q), bin), b.count(k, S::Quantity(q), bin));
        EXPECT_EQ(a.energy(k, S::Quantity(q), bin), b.energy(k, S::Quantity(q), bin));
      }
  }
  EXPECT_EQ(a.dissipated(), b.dissipated());
}

void expect_mill_spectra_for_any_thread_count(const std::vector<std::string>& overrides) {
  const test::AllowThreads allow_three(3);
  const std::unique_ptr<World> one = fines_mill_world(1, overrides);
  ASSERT_EQ(one->run_until(0.4), StepStatus::ok);
  const S& spectra = *one->collision_spectra();
  ASSERT_EQ(spectra.class_count(), 2);
  // The fines meet balls, each other and the liner.
  EXPECT_GT(spectra.events(spectra.pair_kind(0, 1)), 10u);
  EXPECT_GT(spectra.events(spectra.pair_kind(1, 1)), 100u);
  EXPECT_GT(spectra.events(spectra.wall_kind(0)), 0u);
  EXPECT_GT(spectra.events(spectra.wall_kind(1)), 10u);
  EXPECT_NEAR(spectra.dissipation_share(0) + spectra.dissipation_share(1), 1, 1e-12);
  const Real lost = one->dissipated_energy();
  const Real open = live_dissipation(one->pair_contacts().work, one->pair_contacts().elastic) +
                    live_dissipation(one->wall_contacts().work, one->wall_contacts().elastic);
  EXPECT_NEAR(spectra.dissipated() + open, lost, 1e-9 * lost);
  const std::unique_ptr<World> three = fines_mill_world(3, overrides);
  ASSERT_EQ(three->run_until(0.4), StepStatus::ok);
  ASSERT_EQ(three->thread_count(), 3);
  EXPECT_EQ(three->state_hash(), one->state_hash());
  expect_same_spectra(*three->collision_spectra(), spectra);
}

TEST(SpectraKinds, AMillWithFinesBooksTheSameKindsForAnyThreadCount) { expect_mill_spectra_for_any_thread_count({}); }

TEST(SpectraKinds, AMillWithFinesUnderLevelsPerParticleBooksTheSameKindsForAnyThreadCount) {
  expect_mill_spectra_for_any_thread_count({"integrator.control=\"doubling\"", "integrator.particle_levels=true"});
}

TEST(SpectraKinds, ACheckpointCarriesTheSpectraPerKind) {
  for (const bool doubling : {false, true}) {
    SCOPED_TRACE(doubling ? "step doubling" : "fixed step");
    const std::vector<std::string> overrides =
        doubling ? std::vector<std::string>{"integrator.control=\"doubling\"", "integrator.particle_levels=true"}
                 : std::vector<std::string>{};
    const std::unique_ptr<World> straight = fines_mill_world(1, overrides);
    ASSERT_EQ(straight->run_until(0.3), StepStatus::ok);
    const std::unique_ptr<World> first = fines_mill_world(1, overrides);
    ASSERT_EQ(first->run_until(0.15), StepStatus::ok);
    ASSERT_GT(first->collision_spectra()->events(first->collision_spectra()->pair_kind(0, 1)), 0u);
    const auto path = std::filesystem::temp_directory_path() /
                      ("dem_spectra_kinds_test_" + std::to_string(::getpid()) + (doubling ? "_d" : "_f"));
    first->save_checkpoint(path.string(), {5, 5});
    const std::unique_ptr<World> resumed = fines_mill_world(1, overrides);
    resumed->load_checkpoint(path.string(), {5, 5});
    std::filesystem::remove(path);
    expect_same_spectra(*resumed->collision_spectra(), *first->collision_spectra());
    ASSERT_EQ(resumed->run_until(0.3), StepStatus::ok);
    EXPECT_EQ(resumed->state_hash(), straight->state_hash());
    expect_same_spectra(*resumed->collision_spectra(), *straight->collision_spectra());
  }
}

TEST(SpectraKinds, ACheckpointOfOtherSizeClassesIsRefused) {
  const std::unique_ptr<World> two = fines_mill_world(1, {});
  ASSERT_EQ(two->run_until(0.01), StepStatus::ok);
  const auto path = std::filesystem::temp_directory_path() / ("dem_spectra_kinds_test_classes_" + std::to_string(::getpid()));
  two->save_checkpoint(path.string(), {5, 5});
  const std::unique_ptr<World> three = fines_mill_world(1, {"mill.size_classes=[0.001, 0.002]"});
  EXPECT_THROW(three->load_checkpoint(path.string(), {5, 5}), std::runtime_error);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace dem

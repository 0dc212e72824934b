// Mills (docs/physics.md 7): a single ball's motion against the critical speed, power draw against speed,
// and the energy balance of a running charge, on small 2D mills.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "engine/mill_monitor.h"
#include "engine/scene_loader.h"
#include "engine/world.h"
#include "tests/mill_scenes.h"
#include "tests/thread_support.h"

namespace dem {
namespace {

using test::ball_radius;
using test::mill_radius;
using test::mill_scene;

struct MillRun {
  Scene scene;
  std::unique_ptr<World> world;
  std::unique_ptr<MillMonitor> monitor;
  /// `edit` may change the loaded scene (say, where a particle starts) before the World is made.
  explicit MillRun(const std::string& text, const std::function<void(Scene&)>& edit = {})
      : scene(load_scene_text(text, "mill.toml", ".")) {
    if (edit) edit(scene);
    world = std::make_unique<World>(scene.world);
    monitor = std::make_unique<MillMonitor>(*scene.mill, *world);
  }
  Real period() const { return 2 * pi / scene.mill->speed; }
  /// Advances to time t, calling `each` at every sync time.
  template <class F>
  void run_until(Real t, F&& each) {
    while (world->time() < t) {
      ASSERT_EQ(world->advance_sync_interval(), StepStatus::ok);
      monitor->observe(*world);
      each();
    }
  }
  void run_until(Real t) {
    run_until(t, [] {});
  }
  const Vec3& ball() const { return world->state().position[0]; }
};

TEST(Mill, CriticalSpeedMatchesTheClassicFormula) {
  // N_c = 42.3 / sqrt(D - d) rpm (docs/physics.md 7.1): D = 5 m, d = 0.1 m gives 19.1 rpm.
  EXPECT_NEAR(critical_speed(5, 0.1, 9.81) * 60 / (2 * pi), 42.3 / std::sqrt(4.9), 0.01);
}

// A disc at rest on the bottom of a smooth drum that spins up to 0.3 of the critical speed over the
// ramp (0.2 s). Rolling on the shell, it turns at Omega R_d / r; spinning it up at the ramp's
// Omega' = 0.3 Omega_c / 0.2 s takes a tangential force F_t = (I / r^2) Omega' R_d = m Omega' R_d / 2,
// which holds the disc up the rising side where m g sin(theta) = F_t: about 4.4 degrees here. It
// swings about that, and once the drum turns steadily about tan(theta) = mu_r (1.1 degrees, rolling
// resistance), by no more than it swung in the ramp: within twice the ramp's angle, watched over two
// revolutions after the ramp. Nothing in a smooth drum carries it up.
TEST(Mill, SingleBallWithoutLiftersStaysNearTheBottom) {
  const Real fraction = 0.3, ramp_time = 0.2;  // the scene's critical_fraction and ramp_time
  MillRun run(mill_scene(0, fraction, "count = 1"),
              [](Scene& s) { s.world.particles[0].position = Vec3(0, -(mill_radius - ball_radius), 0); });
  const Real critical = std::sqrt(9.81 / (mill_radius - ball_radius));  // [rad/s]
  const Real ramp_angle = std::asin(0.5 * (fraction * critical / ramp_time) * mill_radius / 9.81);
  run.run_until(0.6);
  Real highest = -1;  // the ball's highest angle above the bottom, seen from the axis [rad]
  run.run_until(0.6 + 2 * run.period(), [&] {
    highest = std::max(highest, std::atan2(std::abs(run.ball().x()), -run.ball().y()));
  });
  EXPECT_LT(highest, 2 * ramp_angle) << "a ball rolling in a smooth drum rocks about the bottom";
  EXPECT_GE(highest, 0);
}

TEST(Mill, LiftersCarryABallUpAndReleaseIt) {
  MillRun run(mill_scene(8, 0.75, "count = 1"));
  run.run_until(0.6);
  int lifts = 0;  // times the ball rose above the axis and came back down to the bottom
  bool up = false;
  run.run_until(0.6 + 3 * run.period(), [&] {
    const Real y = run.ball().y();
    if (!up && y > 0) up = true, ++lifts;
    if (up && y < -0.8 * mill_radius) up = false;
  });
  EXPECT_GE(lifts, 2) << "carried above the axis and dropped, revolution after revolution";
}

TEST(Mill, AboveCriticalSpeedTheBallIsCarriedRound) {
  MillRun run(mill_scene(8, 1.5, "count = 1"));
  run.run_until(0.6);
  Real nearest = 1, top = -1;  // closest approach to the axis, highest point
  run.run_until(0.6 + 3 * run.period(), [&] {
    nearest = std::min(nearest, run.ball().norm());
    top = std::max(top, run.ball().y());
  });
  EXPECT_GT(nearest, mill_radius - 0.012 - 2 * ball_radius) << "it never leaves the shell";
  EXPECT_GT(top, 0.8 * mill_radius) << "it passes the top";
}

Real steady_power(Real critical_fraction) {
  MillRun run(mill_scene(8, critical_fraction, "count = 150"));
  // The ramp's revolution (not steady) and two steady ones.
  run.run_until(0.1 + 3.02 * run.period());
  EXPECT_GE(run.monitor->steady_revolutions(), 2);
  return run.monitor->mean_power_draw().value_or(-1);
}

TEST(Mill, PowerDrawRisesWithSpeedThenFallsAsTheChargeCentrifuges) {
  const Real slow = steady_power(0.5), normal = steady_power(0.75), fast = steady_power(1.5);
  EXPECT_GT(slow, 0);
  EXPECT_LT(slow, normal);
  EXPECT_GT(normal, fast) << "P(50%) = " << slow << " W, P(75%) = " << normal << " W, P(150%) = " << fast << " W";
}

/// What the collision spectra hold: events ended so far plus what open contacts have dissipated.
Real spectra_total(const World& world) {
  return world.collision_spectra()->dissipated() +
         live_dissipation(world.pair_contacts().work, world.pair_contacts().elastic) +
         live_dissipation(world.wall_contacts().work, world.wall_contacts().elastic);
}

TEST(Mill, DriveWorkBalancesDissipationAndEnergyChange) {
  MillRun run(mill_scene(8, 0.75, "count = 150"));
  const Real start = 0.2 + run.period();  // after the ramp and a revolution
  run.run_until(start);
  const Energies e0 = run.world->energies();
  const Real work0 = run.world->wall_work(), lost0 = run.world->dissipated_energy();
  const Real spectra0 = spectra_total(*run.world);
  const std::uint64_t events0 = run.world->collision_spectra()->events(CollisionSpectra::ball_ball);
  run.run_until(start + 2 * run.period());
  const Energies e1 = run.world->energies();
  // Drive work is integrated every step from the walls' power; the dissipation is each contact's own
  // books; the spectra sum their events one by one. The books hold the contact law's losses along the
  // computed path, so the residual is velocity Verlet's own energy error: second order in the step
  // (1.3% of the drive work here at omega0 dt = 0.32, 0.36% at half the step).
  const Real work = run.world->wall_work() - work0;
  const Real lost = run.world->dissipated_energy() - lost0;
  const Real change = e1.total() - e0.total();
  ASSERT_GT(work, 0);
  std::printf("drive work %.6g J: balance residual %.3g of it, spectra residual %.3g\n", work,
              (work - (lost + change)) / work, (spectra_total(*run.world) - spectra0 - (work - change)) / work);
  EXPECT_LT(std::abs(work - (lost + change)), 0.02 * work)
      << "drive work " << work << " J, dissipated " << lost << " J, energy change " << change << " J";
  const Real spectra = spectra_total(*run.world) - spectra0;
  EXPECT_LT(std::abs(spectra - (work - change)), 0.02 * work) << "spectra total " << spectra << " J";
  EXPECT_GT(run.world->collision_spectra()->events(CollisionSpectra::ball_ball), events0 + 100);
}

/// A 1 kg ball hits a plane head-on at 1 m/s without gravity (e = 0.6), spectra booked, fixed dt 1e-6 s.
WorldConfig single_impact() {
  WorldConfig config;
  config.contacts[0].normal_stiffness = 1e5;
  config.contacts[0].normal_damping = {DampingKind::restitution, 0.6};
  config.contacts[0].sliding_friction = 0.3;
  WallConfig floor;
  floor.kind = WallKind::plane;
  config.walls.push_back(floor);
  ParticleConfig ball;
  ball.position = Vec3(0, 0, 0.101);
  ball.velocity = Vec3(0, 0, -1);
  ball.radius = 0.1;
  ball.mass = 1;
  config.particles.push_back(ball);
  config.integrator.dt = 1e-6;
  config.collision_spectra = true;
  return config;
}

TEST(CollisionSpectra, ASingleImpactBooksItsEnergies) {
  // One ball-liner event whose impact energy is m v^2 / 2 = 0.5 J, whose normal loss is (1 - e^2) of
  // it, and no tangential loss.
  World world(single_impact());
  ASSERT_EQ(world.run_until(0.02), StepStatus::ok);
  const CollisionSpectra& spectra = *world.collision_spectra();
  ASSERT_EQ(spectra.events(CollisionSpectra::ball_wall), 1u);
  EXPECT_EQ(spectra.events(CollisionSpectra::ball_ball), 0u);
  EXPECT_NEAR(spectra.total(CollisionSpectra::ball_wall, CollisionSpectra::impact), 0.5, 1e-3);
  EXPECT_NEAR(spectra.total(CollisionSpectra::ball_wall, CollisionSpectra::normal_dissipated), 0.5 * (1 - 0.36), 2e-3);
  EXPECT_NEAR(spectra.total(CollisionSpectra::ball_wall, CollisionSpectra::tangential_dissipated), 0, 1e-12);
  EXPECT_NEAR(spectra.dissipated(), world.dissipated_energy(), 1e-12);
}

TEST(CollisionSpectra, StepDoublingBooksTheSameSingleImpact) {
  // The impact above under step doubling: the island logs the contact when it ends in an accepted
  // step, and the World books the log at the end of the round; rejected trials book nothing.
  WorldConfig config = single_impact();
  config.integrator.control = Control::doubling;
  config.integrator.dt = config.integrator.dt_base = 1e-3;
  config.integrator.level_min = -12;
  config.integrator.level_max = 0;
  config.integrator.tolerance = 1e-4;
  World world(config);
  ASSERT_EQ(world.run_until(0.02), StepStatus::ok);
  ASSERT_NE(world.collision_spectra(), nullptr);
  const CollisionSpectra& spectra = *world.collision_spectra();
  EXPECT_GT(world.counters().rejected_steps, 0u) << "the impact makes the island reject some trials";
  ASSERT_EQ(spectra.events(CollisionSpectra::ball_wall), 1u);
  EXPECT_EQ(spectra.events(CollisionSpectra::ball_ball), 0u);
  EXPECT_NEAR(spectra.total(CollisionSpectra::ball_wall, CollisionSpectra::impact), 0.5, 1e-3);
  EXPECT_NEAR(spectra.total(CollisionSpectra::ball_wall, CollisionSpectra::normal_dissipated), 0.5 * (1 - 0.36), 2e-3);
  EXPECT_NEAR(spectra.dissipated(), world.dissipated_energy(), 1e-12);
}

TEST(Mill, StepDoublingBooksEveryContactEventOnceForAnyThreadCount) {
  // A charge under step doubling, with contacts made and broken in islands at many levels, trials
  // rejected and rounds redone: the spectra (events booked from the islands' logs plus what open
  // contacts have dissipated) hold the World's dissipated energy, which sums the contacts' own books
  // separately; and the islands, which run in parallel, book the same spectra on 1 and 3 threads.
  const test::AllowThreads allow_three(3);
  auto run = [](int threads) {
    const Scene scene = load_scene_text(mill_scene(8, 0.75, "count = 30"), "mill.toml", ".",
                                        {"integrator.control=\"doubling\"", "run.threads=" + std::to_string(threads)});
    auto world = std::make_unique<World>(scene.world);
    EXPECT_EQ(world->run_until(0.4), StepStatus::ok);
    return world;
  };
  const std::unique_ptr<World> world = run(1);
  ASSERT_NE(world->collision_spectra(), nullptr);
  const CollisionSpectra& spectra = *world->collision_spectra();
  EXPECT_GT(spectra.events(CollisionSpectra::ball_ball), 100u);
  EXPECT_GT(spectra.events(CollisionSpectra::ball_wall), 10u);
  EXPECT_GT(world->counters().rejected_steps, 0u);
  EXPECT_GT(world->counters().round_redos, 0u);
  const Real lost = world->dissipated_energy();
  ASSERT_GT(lost, 0);
  EXPECT_NEAR(spectra_total(*world), lost, 1e-9 * lost);
  const std::unique_ptr<World> three = run(3);
  ASSERT_EQ(three->thread_count(), 3);
  EXPECT_EQ(three->state_hash(), world->state_hash());
  const CollisionSpectra& other = *three->collision_spectra();
  for (auto kind : {CollisionSpectra::ball_ball, CollisionSpectra::ball_wall}) {
    EXPECT_EQ(other.events(kind), spectra.events(kind));
    for (auto q : {CollisionSpectra::impact, CollisionSpectra::normal_dissipated, CollisionSpectra::tangential_dissipated})
      for (int b = 0; b < CollisionSpectra::bin_count; ++b) EXPECT_EQ(other.energy(kind, q, b), spectra.energy(kind, q, b));
  }
}

TEST(Mill, RunsUnderEveryControlAndStepper) {
  // The exact stepper handles friction for one particle only so far: its mill is frictionless.
  struct Case {
    const char* name;
    std::vector<std::string> overrides;
  };
  const std::vector<Case> cases = {
      {"verlet, fixed", {}},
      {"verlet, doubling", {"integrator.control=\"doubling\""}},
      {"exact, fixed", {"integrator.method=\"exact\"", "contacts[0].sliding_friction=0.0", "contacts[0].rolling_friction=0.0"}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const Scene scene = load_scene_text(mill_scene(8, 0.75, "count = 30"), "mill.toml", ".", c.overrides);
    World world(scene.world);
    ASSERT_EQ(world.run_until(0.4), StepStatus::ok);
    EXPECT_GT(world.wall_work(), 0) << "the turning shell and lifters do work on the charge";
    const EnergyBalance b = world.energy_balance();
    EXPECT_LT(std::abs(b.error), 0.05 * b.scale) << "error " << b.error << " J of " << b.scale << " J";
  }
}

}  // namespace
}  // namespace dem

// The World's embedding API (world_embedding.cpp): loading a scene file, the callback at sync
// times, contact forces against wall loads (Newton's third law), feeding a particle into free
// space (free-flight oracle, docs/physics.md 8.1), discharging one in contact (momentum and energy
// books), setting a velocity (an impulse the energy books see), and bitwise thread-count determinism of runs with both under both step controls.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>

#include "engine/input_error.h"
#include "engine/scene.h"
#include "engine/world.h"
#include "tests/contact_scenes.h"
#include "tests/test_scenes.h"

namespace dem {
namespace {

const std::string seed_slope = std::string(DEM_SOURCE_DIR) + "/scenes/seed_slope.toml";

TEST(Embedding, LoadBuildsTheWorldOfASceneFile) {
  Scene scene;
  const std::unique_ptr<World> world = World::load(seed_slope, {}, &scene);
  EXPECT_EQ(world->particle_count(), 1u);
  EXPECT_EQ(world->sync_interval(), 0.001);
  EXPECT_EQ(world->walls().count(), 1u);
  EXPECT_EQ(world->find_wall("slope"), std::optional<std::size_t>(0));
  EXPECT_FALSE(world->find_wall("shell").has_value());
  EXPECT_EQ(scene.run.until, 8.0) << "the caller gets the scene's [run] settings";
  EXPECT_EQ(world->position(0), Vec3(0.0, 0.0, 0.980780618756458));
  EXPECT_EQ(world->velocity(0), Vec3(10.0, 0.0, 0.0));

  const std::unique_ptr<World> changed = World::load(seed_slope, {"integrator.dt=0.002", "run.threads=1"});
  EXPECT_EQ(changed->sync_interval(), 0.002);
  EXPECT_EQ(changed->thread_count(), 1);
  EXPECT_THROW(World::load(std::string(DEM_SOURCE_DIR) + "/scenes/no_such_scene.toml"), InputError);
  EXPECT_THROW(World::load(seed_slope, {"integrator.dt=-1"}), InputError);
}

TEST(Embedding, CallbackRunsAtEverySyncTimeUntilTheFirstAtOrAfterTheEnd) {
  const std::unique_ptr<World> world = World::load(seed_slope);
  const Real T = world->sync_interval();
  const Real end = 0.1005;  // between two sync times: the run stops at the 101st
  const long expected = static_cast<long>(std::ceil(end / T));
  long calls = 0;
  bool times_ok = true;
  const StepStatus status = world->run_until(end, [&](const World& w) {
    ++calls;
    times_ok = times_ok && w.clock().interval == calls && w.time() == static_cast<Real>(calls) * T;
    return true;
  });
  EXPECT_EQ(status, StepStatus::ok);
  EXPECT_EQ(expected, 101);
  EXPECT_EQ(calls, expected);
  EXPECT_TRUE(times_ok) << "one call per sync interval, at its end";
  EXPECT_GE(world->time(), end);
  EXPECT_EQ(world->counters().sync_intervals, static_cast<std::uint64_t>(expected));
}

TEST(Embedding, CallbackReturningFalseStopsTheRunThere) {
  const std::unique_ptr<World> world = World::load(seed_slope);
  long calls = 0;
  EXPECT_EQ(world->run_until(1.0, [&](World&) { return ++calls < 10; }), StepStatus::ok);
  EXPECT_EQ(calls, 10);
  EXPECT_EQ(world->clock().interval, 10);
  // The run goes on from there; without a callback as run_until(t).
  EXPECT_EQ(world->run_until(0.02, World::SyncCallback{}), StepStatus::ok);
  EXPECT_EQ(world->clock().interval, 20);
}

/// Sum of -force over the wall contacts of wall w, in list order (accumulate_wall_loads' order).
Vec3 load_from_contacts(const std::vector<ContactForce>& contacts, int w) {
  Vec3 sum = Vec3::Zero();
  for (const ContactForce& c : contacts)
    if (c.wall == w) sum -= c.force;
  return sum;
}

TEST(Embedding, ContactForcesOnAWallSumToItsLoad) {
  // The seed slope: one ball rolling on one plane.
  const std::unique_ptr<World> slope = World::load(seed_slope);
  ASSERT_EQ(slope->run_until(0.5), StepStatus::ok);
  std::vector<ContactForce> contacts = slope->contact_forces();
  ASSERT_EQ(contacts.size(), 1u);
  EXPECT_EQ(contacts[0].wall, 0);
  EXPECT_EQ(contacts[0].particle, 0u);
  EXPECT_GT(contacts[0].overlap, 0);
  EXPECT_NEAR(contacts[0].point.z(), -0.5 * contacts[0].overlap, 1e-12) << "mid-overlap below the slope's surface";
  EXPECT_EQ(load_from_contacts(contacts, 0), slope->wall_loads()[0].force);
  EXPECT_LT(slope->wall_loads()[0].force.z(), 0) << "the ball presses down on the slope";

  // Many particles in a box: pairs and walls. Third law per wall (same order, so the same bits)
  // and per particle: its contact forces sum to its total force.
  WorldConfig c = test::falling_box_scene(3, 3, 3, 5);
  c.threads = 1;
  World box(c);
  test::advance(box, 1500);
  contacts = box.contact_forces();
  std::size_t pairs = 0, walls = 0;
  for (const ContactForce& f : contacts) (f.wall < 0 ? pairs : walls) += 1;
  ASSERT_GT(pairs, 0u);
  ASSERT_GT(walls, 0u);
  EXPECT_EQ(pairs, box.pair_contacts().size());
  EXPECT_EQ(load_from_contacts(contacts, 0), box.wall_loads()[0].force);
  std::map<ParticleId, Vec3> total;
  for (const ContactForce& f : contacts) {
    total.try_emplace(f.particle, Vec3::Zero()).first->second += f.force;
    if (f.wall < 0) total.try_emplace(f.partner, Vec3::Zero()).first->second -= f.force;
  }
  for (const auto& [id, force] : total)
    EXPECT_LE((force - box.state().force[*box.index_of(id)]).norm(), 1e-12 * (1 + force.norm())) << "particle " << id;
}

/// A floor with a few particles resting on it, gravity tilted off the axes, damped contacts.
WorldConfig floor_scene(Control control) {
  WorldConfig c = test::base_config(1e-4);
  c.model.gravity = Vec3(0.3, -0.2, -9.81);
  c.contacts[0].normal_stiffness = 1e4;
  c.contacts[0].normal_damping = {DampingKind::restitution, 0.5};
  c.walls = {test::plane(Vec3::Zero(), Vec3::UnitZ())};
  for (int k = 0; k < 4; ++k) c.particles.push_back(test::particle(Vec3(0.05 * k, 0, 0.0099), Vec3::Zero(), 0.01, 0.01));
  if (control == Control::doubling) {
    c.integrator.control = Control::doubling;
    c.integrator.dt_base = 1e-4;
    c.integrator.level_min = -6;
    c.integrator.level_max = 3;
    c.integrator.tolerance = 1e-4;
    c.broadphase.skin = 100;  // rounds at level_max for the flier (doubling_test's free fall)
  }
  return c;
}

TEST(Embedding, AddedParticleFallsFreelyAsTheOracle) {
  // docs/physics.md 8.1: x = x0 + v0 t + g t^2 / 2, exact for Verlet at any step up to round-off.
  for (Control control : {Control::fixed, Control::doubling}) {
    SCOPED_TRACE(control == Control::fixed ? "fixed" : "doubling");
    World world(floor_scene(control));
    ASSERT_EQ(world.run_until(0.05), StepStatus::ok);
    const Real before = world.energy_balance().error;
    const Vec3 g = world.config().model.gravity, x0(0.1, -2.0, 50.0), v0(1.5, 2.0, 3.0);
    EXPECT_TRUE(world.is_free(x0, 0.1));
    EXPECT_FALSE(world.is_free(Vec3(0, 0, 0.01), 0.01)) << "on a particle";
    EXPECT_FALSE(world.is_free(Vec3(1, 0, 0.005), 0.01)) << "in the floor";
    const ParticleId id = world.add_particle(test::particle(x0, v0, 0.1, 2.0));
    EXPECT_EQ(id, 4u) << "the next id";
    EXPECT_EQ(world.particle_count(), 5u);
    EXPECT_EQ(world.state().level.size(), 5u);
    EXPECT_NEAR(world.energy_balance().error, before, 1e-12 * world.energy_balance().scale)
        << "its energy joins the reference";
    const Real t0 = world.time();
    const Real eps = std::numeric_limits<Real>::epsilon();
    long s = 0;
    bool ok = true;
    world.run_until(t0 + 0.5, [&](const World& w) {
      ++s;
      const Real t = w.time() - t0;
      const Vec3 x = x0 + v0 * t + 0.5 * g * t * t, v = v0 + g * t;
      const Real x_scale = x0.norm() + v0.norm() * t + 0.5 * g.norm() * t * t, v_scale = v0.norm() + g.norm() * t;
      // Round-off of the time itself (t0 + t, then minus t0) enters through v t.
      const Real time_error = 4 * eps * (t0 + t) * v_scale;
      ok = (w.position(id) - x).norm() <= 4.0 * static_cast<Real>(s) * eps * x_scale + time_error &&
           (w.velocity(id) - v).norm() <= 4.0 * static_cast<Real>(s) * eps * v_scale + 4 * eps * (t0 + t) * g.norm();
      EXPECT_TRUE(ok) << "interval " << s << ": " << (w.position(id) - x).norm();
      return ok;
    });
    EXPECT_TRUE(ok);
    EXPECT_GT(s, 100);
    const EnergyBalance b = world.energy_balance();
    EXPECT_LT(std::abs(b.error), 1e-6 * b.scale) << "error " << b.error << " scale " << b.scale;
  }
  EXPECT_THROW(World(floor_scene(Control::fixed)).add_particle(test::particle(Vec3(0, 0, 0.01), Vec3::Zero(), 0.01, 1)),
               std::invalid_argument);
  ParticleConfig bad = test::particle(Vec3(0, 0, 5), Vec3::Zero(), 0.01, 1);
  bad.material = "steel";
  EXPECT_THROW(World(floor_scene(Control::fixed)).add_particle(bad), std::invalid_argument);
}

TEST(Embedding, FeedingAnEmptyWorldRunsAsBuildingItWithThoseParticles) {
  // Built with no particle at all, the skin, the candidate lists and (doubling) the contact level
  // and skin cap come from the particles fed later: the run is the one of a world built with them.
  for (Control control : {Control::fixed, Control::doubling}) {
    SCOPED_TRACE(control == Control::fixed ? "fixed" : "doubling");
    WorldConfig c = floor_scene(control);
    c.broadphase.skin = -1;
    c.particles.clear();
    for (int k = 0; k < 3; ++k)
      c.particles.push_back(test::particle(Vec3(0.03 * k, 0, 0.05 + 0.02 * k), Vec3::Zero(), 0.01, 0.01));
    World built(c);
    WorldConfig empty = c;
    empty.particles.clear();
    World fed(empty);
    EXPECT_EQ(fed.skin(), 0);
    for (const ParticleConfig& p : c.particles) fed.add_particle(p);
    EXPECT_EQ(fed.skin(), built.skin()) << "10% of the smallest radius";
    ASSERT_EQ(built.run_until(0.5), StepStatus::ok);
    ASSERT_EQ(fed.run_until(0.5), StepStatus::ok);
    EXPECT_GT(built.pair_contacts().size() + built.wall_contacts().size(), 0u) << "they landed";
    EXPECT_EQ(fed.state_hash(), built.state_hash());
    EXPECT_NEAR(fed.energy_balance().error, built.energy_balance().error, 1e-12 * built.energy_balance().scale);
  }
}

TEST(Embedding, RemovingAFreeParticleRunsAsNeverHavingHadIt) {
  // Fixed control: a particle touching nothing does not change the others' steps, so after its
  // removal the run is the one of a world built without it (it has the largest id: the same ids).
  WorldConfig c = floor_scene(Control::fixed);
  World twin(c);
  c.particles.push_back(test::particle(Vec3(0.5, 0, 1.0), Vec3(0, 0, 2), 0.01, 0.01));
  World world(c);
  ASSERT_EQ(world.run_until(0.05), StepStatus::ok);
  ASSERT_EQ(twin.run_until(0.05), StepStatus::ok);
  ASSERT_TRUE(world.remove_particle(4));
  EXPECT_EQ(world.state_hash(), twin.state_hash());
  ASSERT_EQ(world.run_until(0.3), StepStatus::ok);
  ASSERT_EQ(twin.run_until(0.3), StepStatus::ok);
  EXPECT_EQ(world.state_hash(), twin.state_hash());
  // The same books, up to the round-off of the removed particle's potential energy (~0.1 J here).
  EXPECT_NEAR(world.energy_balance().error, twin.energy_balance().error, 1e-14);
}

/// Total |m v| of the audited particles: the scale of momentum round-off [kg m/s].
Real momentum_scale(const World& w) {
  Real sum = 0;
  for (std::size_t p = 0; p < w.state().size(); ++p)
    if (is_audited(w.state().inv_mass[p])) sum += w.state().velocity[p].norm() / w.state().inv_mass[p];
  return sum;
}

/// The live particle with the most pair contacts (smallest id on a tie).
ParticleId most_touching(const World& w) {
  std::map<ParticleId, int> count;
  for (const ContactForce& c : w.contact_forces())
    if (c.wall < 0) ++count[c.particle], ++count[c.partner];
  ParticleId best = 0;
  int most = -1;
  for (const auto& [id, n] : count)
    if (n > most) best = id, most = n;
  return best;
}

bool same_history(const ContactHistory& a, const ContactHistory& b) {
  return a.tangential_spring == b.tangential_spring && a.rolling_spring == b.rolling_spring && a.mode == b.mode;
}

/// Every particle's total force against the sum of its contact forces.
void expect_forces_are_contact_sums(const World& w) {
  std::map<ParticleId, Vec3> total;
  for (const ContactForce& f : w.contact_forces()) {
    total.try_emplace(f.particle, Vec3::Zero()).first->second += f.force;
    if (f.wall < 0) total.try_emplace(f.partner, Vec3::Zero()).first->second -= f.force;
  }
  for (std::size_t p = 0; p < w.state().size(); ++p) {
    const auto it = total.find(w.state().id[p]);
    const Vec3 expected = it == total.end() ? Vec3(Vec3::Zero()) : it->second;
    EXPECT_LE((w.state().force[p] - expected).norm(), 1e-12 * (1 + expected.norm())) << "particle " << w.state().id[p];
  }
}

/// The box of falling spheres (test_scenes.h, n x n x 3) under the fixed control or step doubling.
WorldConfig box_scene(Control control, int threads, std::uint64_t seed, int n = 3) {
  WorldConfig c = test::falling_box_scene(n, n, 3, seed);
  c.threads = threads;
  if (control == Control::doubling) {
    c.integrator.control = Control::doubling;
    c.integrator.dt_base = 2e-5;
    c.integrator.level_min = -4;
    c.integrator.level_max = 3;
  }
  return c;
}

TEST(Embedding, RemovingAParticleInContactKeepsTheBooksAndTheOthersHistory) {
  for (Control control : {Control::fixed, Control::doubling}) {
    SCOPED_TRACE(control == Control::fixed ? "fixed" : "doubling");
    World world(box_scene(control, 1, 5));
    ASSERT_EQ(world.run_until(0.03), StepStatus::ok);
    const ParticleId id = most_touching(world);
    const ParticleIndex slot = *world.index_of(id);
    const Vec3 p_removed = world.state().velocity[slot] / world.state().inv_mass[slot];
    const Vec3 p_before = world.linear_momentum();
    const Real p_scale = momentum_scale(world);
    const EnergyBalance b_before = world.energy_balance();
    EXPECT_EQ(world.removed_energy(), 0);
    std::map<std::uint64_t, ContactHistory> kept_pairs, kept_walls;
    std::size_t its_pairs = 0;
    for (std::size_t k = 0; k < world.pair_contacts().size(); ++k) {
      const std::uint64_t key = world.pair_contacts().key[k];
      if ((key >> 32) == id || (key & 0xffffffffu) == id) ++its_pairs;
      else kept_pairs[key] = world.pair_contacts().history(k);
    }
    for (std::size_t k = 0; k < world.wall_contacts().size(); ++k) {
      const std::uint64_t key = world.wall_contacts().key[k];
      if ((key >> 32) != id) kept_walls[key] = world.wall_contacts().history[k];
    }
    ASSERT_GT(its_pairs, 0u) << "the particle removed touches others";
    ASSERT_GT(kept_pairs.size(), 0u);

    ASSERT_TRUE(world.remove_particle(id));
    EXPECT_EQ(world.particle_count(), 26u);
    EXPECT_EQ(world.state().level.size(), 26u);
    EXPECT_FALSE(world.index_of(id).has_value());
    EXPECT_THROW(world.position(id), std::out_of_range);
    EXPECT_FALSE(world.remove_particle(id)) << "only once";
    EXPECT_FALSE(world.remove_particle(1000)) << "an id never given";
    // Momentum: the others' is untouched.
    EXPECT_LE((world.linear_momentum() - (p_before - p_removed)).norm(), 1e-14 * p_scale);
    // Energy: what it carried out is booked, so the balance's error does not move.
    const EnergyBalance b_after = world.energy_balance();
    EXPECT_GT(world.removed_energy(), 0);
    EXPECT_NEAR(b_after.error, b_before.error, 1e-12 * b_after.scale);
    // The others' contacts keep their history; their forces are re-summed without it.
    ASSERT_EQ(world.pair_contacts().size(), kept_pairs.size());
    for (std::size_t k = 0; k < world.pair_contacts().size(); ++k) {
      const auto it = kept_pairs.find(world.pair_contacts().key[k]);
      ASSERT_NE(it, kept_pairs.end());
      EXPECT_TRUE(same_history(it->second, world.pair_contacts().history(k)));
    }
    ASSERT_EQ(world.wall_contacts().size(), kept_walls.size());
    for (std::size_t k = 0; k < world.wall_contacts().size(); ++k) {
      const auto it = kept_walls.find(world.wall_contacts().key[k]);
      ASSERT_NE(it, kept_walls.end());
      EXPECT_TRUE(same_history(it->second, world.wall_contacts().history[k]));
    }
    expect_forces_are_contact_sums(world);
    // The run goes on and its books stay as balanced as those of the same run without the removal
    // (this coarse scene's own error is ~2% of the energy in play).
    ASSERT_EQ(world.run_until(0.05), StepStatus::ok);
    World twin(box_scene(control, 1, 5));
    ASSERT_EQ(twin.run_until(0.05), StepStatus::ok);
    const EnergyBalance b_end = world.energy_balance(), b_twin = twin.energy_balance();
    std::printf("%s: removed %g J; balance error before removal %.3e, after %.3e, at 0.05 s %.3e (scale %.3e), "
                "without the removal %.3e (scale %.3e)\n",
                control == Control::fixed ? "fixed" : "doubling", world.removed_energy(), b_before.error,
                b_after.error, b_end.error, b_end.scale, b_twin.error, b_twin.scale);
    EXPECT_LT(std::abs(b_end.error) / b_end.scale, 1.5 * std::abs(b_twin.error) / b_twin.scale);
  }
}

struct FeedRun {
  std::uint64_t hash = 0;
  int added = 0, removed = 0;
  std::size_t particles = 0;
};

/// A box of 75 spheres with a feed at its top and a discharge of the most-touching particle, at sync
/// times. Method exact: frictionless (the exact stepper's friction is for one particle so far).
FeedRun feed_and_discharge(Control control, Method method, int threads) {
  WorldConfig c = box_scene(control, threads, 9, 5);
  if (method == Method::exact) {
    c.integrator.method = Method::exact;
    c.contacts[0].sliding_friction = 0;
    c.contacts[0].rolling_friction = 0;
  }
  World world(c);
  const long intervals = control == Control::fixed ? 1600 : 200;
  FeedRun r;
  long syncs = 0;
  const Vec3 spot(0.026, 0.026, 0.06);  // near the lid of the box, above the falling spheres
  const StepStatus status = world.run_until(static_cast<Real>(intervals) * world.sync_interval(), [&](World& w) {
    ++syncs;
    if (syncs % (intervals / 8) == 0 && w.is_free(spot, 0.0045)) {
      w.add_particle(test::particle(spot, Vec3(0.1, 0, -0.5), 0.0045, 0));
      ++r.added;
    }
    if (syncs % (intervals / 5) == 0) r.removed += w.remove_particle(most_touching(w)) ? 1 : 0;
    return true;
  });
  EXPECT_EQ(status, StepStatus::ok);
  EXPECT_EQ(syncs, intervals);
  r.hash = world.state_hash();
  r.particles = world.particle_count();
  EXPECT_EQ(world.state().level.size(), r.particles);
  const EnergyBalance b = world.energy_balance();
  EXPECT_LT(std::abs(b.error), 0.05 * b.scale) << "error " << b.error << " scale " << b.scale;
  return r;
}

TEST(Embedding, FeedAndDischargeGiveTheSameHashForOneAndTwoThreads) {
  for (Method method : {Method::verlet, Method::exact})
    for (Control control : {Control::fixed, Control::doubling}) {
      const std::string name = std::string(method == Method::verlet ? "verlet" : "exact") + ", " +
                               (control == Control::fixed ? "fixed" : "doubling");
      SCOPED_TRACE(name);
      const FeedRun one = feed_and_discharge(control, method, 1);
      EXPECT_GE(one.added, 2);
      EXPECT_EQ(one.removed, 5);
      EXPECT_EQ(one.particles, 75u + one.added - one.removed);
      const FeedRun two = feed_and_discharge(control, method, 2);
      EXPECT_EQ(two.hash, one.hash);
      EXPECT_EQ(two.added, one.added);
      std::printf("%s: added %d, removed %d, hash %016llx\n", name.c_str(), one.added, one.removed,
                  static_cast<unsigned long long>(one.hash));
    }
}

// A particle flying free under gravity given a new velocity at a sync time flies from there as the
// oracle says (docs/physics.md 8.1), the others do not notice, and the kinetic energy it was given is
// booked, so the balance's error does not move.
TEST(Embedding, SetVelocityIsAnImpulseTheBooksSee) {
  for (Control control : {Control::fixed, Control::doubling}) {
    SCOPED_TRACE(control == Control::fixed ? "fixed" : "doubling");
    WorldConfig config = floor_scene(control);
    config.particles[3].position.z() = 0.5;  // the fourth one flies above the floor
    World world(config);
    ASSERT_EQ(world.run_until(0.01), StepStatus::ok);
    const EnergyBalance before = world.energy_balance();
    const Vec3 v0(0.2, -0.1, 1.5);
    const Vec3 x0 = world.position(3);
    const Real t0 = world.time();
    const Real mass = 1 / world.state().inv_mass[*world.index_of(3)];
    const Real kinetic_before = 0.5 * mass * world.velocity(3).squaredNorm();
    EXPECT_FALSE(world.set_velocity(99, v0)) << "an id never given";
    EXPECT_FALSE(world.set_velocity(3, Vec3(std::nan(""), 0, 0)));
    EXPECT_EQ(world.given_energy(), 0);
    ASSERT_TRUE(world.set_velocity(3, v0));
    EXPECT_EQ(world.velocity(3), v0);
    EXPECT_NEAR(world.given_energy(), 0.5 * mass * v0.squaredNorm() - kinetic_before, 1e-15);
    EXPECT_NEAR(world.energy_balance().error, before.error, 1e-12 * before.scale);
    ASSERT_EQ(world.run_until(0.1), StepStatus::ok);
    const Real t = world.time() - t0;
    const Vec3 oracle = x0 + v0 * t + 0.5 * config.model.gravity * t * t;
    EXPECT_LE((world.position(3) - oracle).norm(), 1e-12);
  }
  WorldConfig flat = floor_scene(Control::fixed);
  flat.model.dimension = 2;
  flat.model.gravity.z() = 0;
  for (ParticleConfig& p : flat.particles) p.position.z() = 0;
  flat.walls = {test::plane(Vec3(0, -0.01, 0), Vec3::UnitY())};
  World disc_world(flat);
  EXPECT_FALSE(disc_world.set_velocity(0, Vec3(0, 0, 1))) << "discs move in the plane";
  EXPECT_TRUE(disc_world.set_velocity(0, Vec3(1, 0, 0)));
}

// The energy an embedding program gave by set_velocity goes into checkpoints: a resumed run balances
// as the straight one does.
TEST(Embedding, GivenEnergyGoesOnAfterAResume) {
  WorldConfig config = box_scene(Control::fixed, 1, 8);
  World straight(config), first(config), resumed(config);
  for (World* w : {&straight, &first}) {
    ASSERT_EQ(w->run_until(0.03), StepStatus::ok);
    ASSERT_TRUE(w->set_velocity(0, Vec3(0, 0, 0.3)));
  }
  ASSERT_GT(first.given_energy(), 0);
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("dem_embedding_books_" + std::to_string(::getpid()));
  first.save_checkpoint(path.string(), {3, 3});
  resumed.load_checkpoint(path.string(), {3, 3});
  std::filesystem::remove(path);
  ASSERT_EQ(straight.run_until(0.06), StepStatus::ok);
  ASSERT_EQ(resumed.run_until(0.06), StepStatus::ok);
  EXPECT_EQ(resumed.given_energy(), straight.given_energy());
  EXPECT_EQ(resumed.energy_balance().error, straight.energy_balance().error);
  EXPECT_EQ(resumed.state_hash(), straight.state_hash());
}

}  // namespace
}  // namespace dem

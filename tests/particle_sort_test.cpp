// Re-sorting particles in memory (World, broadphase.sort_interval) changes where particles are
// stored, never how they move: every particle's contacts are summed in partner id order, so runs that
// re-sort every few steps and runs that never do end with the same bits, on mills with lifters,
// friction, rolling resistance and collision spectra, in 2D and 3D, and with particles fed and
// discharged. The books summed over slots (dissipated energy, wall loads) differ only by round-off, and
// a resumed run re-sorts where the straight run did, so its books are the same bits too.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "broadphase/candidate_pairs.h"
#include "engine/neighbour_contacts.h"
#include "engine/scene_loader.h"
#include "engine/spatial_order.h"
#include "engine/state.h"
#include "engine/world.h"
#include "test_scenes.h"

namespace dem {
namespace {

std::string scene(const std::string& name) { return std::string(DEM_SOURCE_DIR) + "/scenes/" + name; }

std::unique_ptr<World> load(const std::string& name, int sort_interval, const std::string& threads = "2") {
  return World::load(scene(name), {"run.threads=" + threads, "broadphase.sort_interval=" + std::to_string(sort_interval)});
}

void advance(World& world, int steps) {
  for (int s = 0; s < steps; ++s) ASSERT_EQ(world.advance_sync_interval(), StepStatus::ok);
}

/// How far two ids' slots lie apart in memory, on average over the touching pairs.
double mean_slot_distance(const World& world) {
  const PairContacts& pairs = world.pair_contacts();
  double sum = 0;
  for (std::size_t k = 0; k < pairs.size(); ++k)
    sum += std::abs(static_cast<double>(pairs.i[k]) - static_cast<double>(pairs.j[k]));
  return pairs.size() > 0 ? sum / static_cast<double>(pairs.size()) : 0;
}

TEST(ParticleSort, PermuteMovesEveryArrayAndKeepsIdsWithTheirParticles) {
  State s;
  for (int p = 0; p < 4; ++p)
    s.add(Vec3(p, 0, 0), Vec3(0, p, 0), Vec3(0, 0, p), 1 + p, 1.0 / (1 + p), 2.0 / (1 + p), static_cast<std::uint16_t>(p));
  s.remove(1);  // ids 0, 2, 3 in slots 0, 1, 2
  s.force[2] = Vec3(7, 7, 7);
  s.level[0] = -2;
  ASSERT_TRUE(s.slots_follow_ids());
  const Vec3* storage = s.position.data();
  s.permute({2, 0, 1});  // slot 0 takes the particle of slot 2 (id 3), ...
  EXPECT_EQ(s.id, (std::vector<ParticleId>{3, 0, 2}));
  EXPECT_FALSE(s.slots_follow_ids());
  EXPECT_EQ(s.position.data(), storage) << "in place: views of the arrays stay valid";
  for (std::size_t q = 0; q < s.size(); ++q) {
    const Real p = s.id[q];  // each particle was made from its id
    EXPECT_EQ(s.position[q], Vec3(p, 0, 0));
    EXPECT_EQ(s.velocity[q], Vec3(0, p, 0));
    EXPECT_EQ(s.angular_velocity[q], Vec3(0, 0, p));
    EXPECT_EQ(s.radius[q], 1 + p);
    EXPECT_EQ(s.inv_mass[q], 1.0 / (1 + p));
    EXPECT_EQ(s.inv_inertia[q], 2.0 / (1 + p));
    EXPECT_EQ(s.material[q], static_cast<std::uint16_t>(p));
    EXPECT_EQ(s.index_of_id[s.id[q]], q);
  }
  EXPECT_EQ(s.force[0], Vec3(7, 7, 7));
  EXPECT_EQ(s.level[1], -2);
  EXPECT_EQ(s.index_of_id[1], removed_slot);
  // A particle added later takes the last slot with the next id.
  EXPECT_EQ(s.add(Vec3::Zero(), Vec3::Zero(), Vec3::Zero(), 1, 1, 1, 0), 3u);
  EXPECT_EQ(s.id[3], 4u);
}

TEST(ParticleSort, OrientByIdPutsEachPairInTheRowOfItsSmallerIdByAscendingPartnerId) {
  State s;
  for (int p = 0; p < 5; ++p) s.add(Vec3(p, 0, 0), Vec3::Zero(), Vec3::Zero(), 1, 1, 1, 0);
  s.permute({4, 2, 0, 3, 1});  // slots hold ids 4, 2, 0, 3, 1
  broadphase::CandidatePairs by_slot;  // every pair, rows by the smaller slot
  by_slot.row_start = {0};
  for (std::uint32_t a = 0; a < 5; ++a) {
    for (std::uint32_t b = a + 1; b < 5; ++b) by_slot.partner.push_back(b);
    by_slot.row_start.push_back(static_cast<std::uint32_t>(by_slot.partner.size()));
  }
  broadphase::CandidatePairs by_id;
  std::vector<std::uint32_t> cursor;
  orient_by_id(s, by_slot, by_id, cursor);
  ASSERT_EQ(by_id.row_count(), 5u);
  ASSERT_EQ(by_id.pair_count(), 10u);
  for (std::uint32_t a = 0; a < 5; ++a) {
    std::vector<ParticleId> partners;
    for (std::uint32_t k = by_id.row_start[a]; k < by_id.row_start[a + 1]; ++k) partners.push_back(s.id[by_id.partner[k]]);
    std::vector<ParticleId> larger;  // every id above a's, ascending
    for (ParticleId id = s.id[a] + 1; id < 5; ++id) larger.push_back(id);
    EXPECT_EQ(partners, larger) << "row of id " << s.id[a];
  }
}

/// A shipped scene with collision spectra booked, threads and sort interval set.
WorldConfig shipped(const std::string& name, int sort_interval) {
  WorldConfig c = load_scene(scene(name)).world;
  c.threads = 2;
  c.collision_spectra = true;
  c.broadphase.sort_interval = sort_interval;
  return c;
}

/// Falling polydisperse spheres in a closed box, with friction and rolling resistance (3D).
WorldConfig falling_box(int sort_interval) {
  WorldConfig c = test::falling_box_scene(12, 12, 8, 3);
  c.threads = 2;
  c.collision_spectra = true;
  c.broadphase.sort_interval = sort_interval;
  return c;
}

TEST(ParticleSort, BinOrderSweepsTheBinsRowByRowXFastest) {
  // A 3 x 3 x 3 lattice of spacing 1, shuffled, in bins of 1: the lattice comes back x fastest, then
  // y, then z; two points in one bin keep their index order.
  std::vector<Vec3> points;
  for (int k = 0; k < 27; ++k) points.push_back(Vec3((k * 7) % 3, (k * 7) / 3 % 3, (k * 7) / 9 % 3) + Vec3::Constant(0.1));
  points.push_back(points[5] + Vec3::Constant(0.2));  // index 27, the bin of index 5
  const std::vector<std::uint32_t> order = bin_order(points, 1.0);
  ASSERT_EQ(order.size(), points.size());
  std::vector<Vec3> swept;
  for (std::uint32_t q : order) swept.push_back(points[q].array().floor().matrix());
  std::size_t at = 0;
  for (int z = 0; z < 3; ++z)
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 3; ++x) {
        ASSERT_EQ(swept[at], Vec3(x, y, z)) << "place " << at;
        at += swept[at] == points[5].array().floor().matrix() ? 2 : 1;  // the shared bin holds two
      }
  const auto five = std::find(order.begin(), order.end(), 5u);
  ASSERT_NE(five + 1, order.end());
  EXPECT_EQ(*(five + 1), 27u) << "ties in index order";
  // Far-flung points: the bins grow so that no axis needs more than 2^21 of them, and order still holds.
  const std::vector<Vec3> far = {Vec3(1e9, 0, 0), Vec3(0, 0, 0), Vec3(5e8, 0, 0)};
  EXPECT_EQ(bin_order(far, 1e-3), (std::vector<std::uint32_t>{1, 2, 0}));
  // A non-finite coordinate (a run about to stop on it) leaves the order as it is.
  const std::vector<Vec3> broken = {Vec3(2, 0, 0), Vec3(std::nan(""), 0, 0), Vec3(1, 0, 0)};
  EXPECT_EQ(bin_order(broken, 1.0), (std::vector<std::uint32_t>{0, 1, 2}));
}

struct SortCase {
  const char* name;
  WorldConfig (*config)(int sort_interval);
  int steps;
};

class ResortingMovesNoResult : public testing::TestWithParam<SortCase> {};

TEST_P(ResortingMovesNoResult, SameBitsAsARunThatNeverResorts) {
  const SortCase c = GetParam();
  World often(c.config(7)), never(c.config(0));
  ASSERT_NO_FATAL_FAILURE(advance(often, c.steps));
  ASSERT_NO_FATAL_FAILURE(advance(never, c.steps));
  EXPECT_TRUE(never.state().slots_follow_ids());
  EXPECT_FALSE(often.state().slots_follow_ids());
  EXPECT_GT(often.counters().pair_rebuilds, 10u) << "re-sorted at many rebuilds";
  EXPECT_EQ(often.state_hash(), never.state_hash());
  const State& s = never.state();
  for (std::size_t p = 0; p < s.size(); ++p) {
    ASSERT_EQ(often.position(s.id[p]), s.position[p]) << "id " << s.id[p];
    ASSERT_EQ(often.angular_velocity(s.id[p]), s.angular_velocity[p]) << "id " << s.id[p];
  }
  // What divergence messages name does not depend on the slots' order either.
  EXPECT_EQ(often.fastest_particle().particle, never.fastest_particle().particle);
  EXPECT_EQ(often.deepest_overlap().particle, never.deepest_overlap().particle);
  // Sums over slots differ by round-off only.
  const Real dissipated = never.dissipated_energy();
  EXPECT_GT(dissipated, 0);
  EXPECT_NEAR(often.dissipated_energy(), dissipated, 1e-12 * dissipated);
  ASSERT_NE(often.collision_spectra(), nullptr);
  EXPECT_EQ(often.collision_spectra()->books().events, never.collision_spectra()->books().events);
  // Neighbours in space are neighbours in memory: slots in random order would put touching pairs a
  // third of the particles apart on average.
  EXPECT_LT(mean_slot_distance(often), 0.1 * static_cast<double>(s.size()));
}

INSTANTIATE_TEST_SUITE_P(Scenes, ResortingMovesNoResult,
                         testing::Values(SortCase{"mill2d", [](int n) { return shipped("mill_2d.toml", n); }, 1500},
                                         SortCase{"fallingbox", falling_box, 1500}),
                         [](const testing::TestParamInfo<SortCase>& param) { return std::string(param.param.name); });

TEST(ParticleSort, FeedAndDischargeBetweenResortsMoveNoResult) {
  const std::unique_ptr<World> often = load("mill_2d.toml", 5), never = load("mill_2d.toml", 0);
  for (World* w : {often.get(), never.get()}) {
    for (int round = 0; round < 4; ++round) {
      ASSERT_NO_FATAL_FAILURE(advance(*w, 120));
      // Discharge two particles by id; feed one at the first free spot of a grid inside the mill (the
      // same spot in both worlds, whose particles lie in the same places).
      ASSERT_TRUE(w->remove_particle(static_cast<ParticleId>(100 * round + 3)));
      ASSERT_TRUE(w->remove_particle(static_cast<ParticleId>(100 * round + 50)));
      ParticleConfig fed;
      fed.radius = 0.002;
      fed.material = "steel";
      bool placed = false;
      for (int spot = 0; spot < 400 && !placed; ++spot) {
        fed.position = Vec3(-0.1 + 0.01 * (spot % 20), -0.1 + 0.01 * (spot / 20), 0);
        placed = w->is_free(fed.position, fed.radius);
      }
      ASSERT_TRUE(placed);
      w->add_particle(fed);
    }
    ASSERT_NO_FATAL_FAILURE(advance(*w, 200));
  }
  EXPECT_FALSE(often->state().slots_follow_ids());
  EXPECT_EQ(often->state_hash(), never->state_hash());
  const EnergyBalance balance = often->energy_balance();
  EXPECT_LT(std::abs(balance.error), 1e-6 * balance.scale);
}

TEST(ParticleSort, AResumedRunResortsWhereTheStraightRunDid) {
  // Re-sorts every 400 steps: at the first rebuild, then at the first at or after step 400 or so,
  // and 800 or so. The checkpoint at step 700 must carry the layout and when the last re-sort was:
  // a resumed run that re-sorted at once would hold another layout until step 800, and its books,
  // summed over slots, would drift from the straight run's by round-off.
  WorldConfig config = falling_box(400);
  config.threads = 1;
  const auto straight = std::make_unique<World>(config);
  ASSERT_NO_FATAL_FAILURE(advance(*straight, 700));
  const auto path = std::filesystem::temp_directory_path() / "dem_particle_sort_resume.bin";
  straight->save_checkpoint(path.string(), {1, 1});
  config.threads = 2;
  const auto resumed = std::make_unique<World>(config);
  resumed->load_checkpoint(path.string(), {1, 1});
  std::filesystem::remove(path);
  for (World* w : {straight.get(), resumed.get()}) ASSERT_NO_FATAL_FAILURE(advance(*w, 50));
  EXPECT_EQ(resumed->state().id, straight->state().id) << "the same layout between two re-sorts";
  EXPECT_FALSE(straight->state().slots_follow_ids());
  for (World* w : {straight.get(), resumed.get()}) ASSERT_NO_FATAL_FAILURE(advance(*w, 300));
  EXPECT_EQ(resumed->state_hash(), straight->state_hash());
  EXPECT_EQ(resumed->state().id, straight->state().id);
  EXPECT_EQ(resumed->dissipated_energy(), straight->dissipated_energy());
  EXPECT_EQ(resumed->energies().elastic, straight->energies().elastic);
  EXPECT_EQ(resumed->wall_loads()[0].torque, straight->wall_loads()[0].torque);
}

}  // namespace
}  // namespace dem

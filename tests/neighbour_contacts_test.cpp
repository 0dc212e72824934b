// The persistent pair list of fixed-step Verlet (engine/neighbour_contacts.h): history moves with
// the candidate pairs at rebuilds, contacts that leave the candidates end and are booked, and what
// the World derives from the list (the compact contact list, the gathered forces, the deepest
// overlap) agrees with the compact-list routines and with an independent overlap search.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <set>
#include <string>

#include "broadphase/grid.h"
#include "engine/forces.h"
#include "engine/neighbour_contacts.h"
#include "engine/step_watch.h"
#include "engine/world.h"

namespace dem {
namespace {

std::string scene(const std::string& name) { return std::string(DEM_SOURCE_DIR) + "/scenes/" + name; }

bool same_bits(const Vec3& a, const Vec3& b) {
  return std::memcmp(a.data(), b.data(), sizeof(double) * 3) == 0;
}

// Three spheres on the x axis: 0 and 1 overlap, 2 is far from both.
State three_spheres() {
  State s;
  s.add(Vec3(0, 0, 0), Vec3::Zero(), Vec3::Zero(), 0.01, 1, 1, 0);
  s.add(Vec3(0.019, 0, 0), Vec3::Zero(), Vec3::Zero(), 0.01, 1, 1, 0);
  s.add(Vec3(1, 0, 0), Vec3::Zero(), Vec3::Zero(), 0.01, 1, 1, 0);
  return s;
}

// A compact list (key order, rows indexed) holding the contacts (0, 1) and (0, 2) with history.
PairContacts compact_list(const State& s) {
  PairContacts c;
  c.parts = {true, false, true};
  c.resize(2);
  const ParticleIndex partner[2] = {1, 2};
  for (std::size_t k = 0; k < 2; ++k) {
    c.key[k] = pair_key(s.id[0], s.id[partner[k]]);
    c.i[k] = 0;
    c.j[k] = partner[k];
    c.tangential_spring[k] = Vec3(0, 1e-5 * static_cast<Real>(k + 1), 0);
    c.mode[k] = mode_sliding;
    c.books[k] = {0.25, 0.125, 1.0};
    c.overlap[k] = 1e-3;
    c.work[k] = 0.5 + static_cast<Real>(k);
    c.elastic[k] = 0.125;
    c.force[k] = Vec3(2, 0, 0);
  }
  c.index_rows(s.size());
  return c;
}

TEST(NeighbourContacts, RebuildCarriesHistoryAndEndsWhatLeftTheCandidates) {
  const State s = three_spheres();
  broadphase::GridBroadphase grid;
  broadphase::CandidatePairs candidates;
  grid.find_pairs(s.position, s.radius, 0.002, candidates);
  ASSERT_EQ(candidates.pair_count(), 1u) << "only (0, 1) is a candidate";
  const PairContacts before = compact_list(s);
  NeighbourContacts nb;
  rebuild_neighbours(s, candidates, before, nb);
  ASSERT_EQ(nb.size(), 1u);
  EXPECT_EQ(nb.touching[0], touching_yes);
  // (0, 2) is no candidate: it is left behind, to end with the next force loop.
  EXPECT_EQ(nb.left_behind, (std::vector<std::uint32_t>{1}));
  EXPECT_EQ(nb.left_dissipated, (std::vector<Real>{before.work[1] - before.elastic[1]}));
  // The compact list made back from the persistent one is (0, 1) with every carried field intact.
  PairContacts after;
  std::vector<std::uint32_t> scratch;
  compact_touching(s, nb, after, scratch);
  ASSERT_EQ(after.size(), 1u);
  EXPECT_EQ(after.key[0], before.key[0]);
  EXPECT_EQ(after.i[0], 0u);
  EXPECT_EQ(after.j[0], 1u);
  EXPECT_TRUE(same_bits(after.tangential_spring[0], before.tangential_spring[0]));
  EXPECT_EQ(after.mode[0], before.mode[0]);
  EXPECT_EQ(after.books[0].normal_work, before.books[0].normal_work);
  EXPECT_EQ(after.work[0], before.work[0]);
  EXPECT_EQ(after.elastic[0], before.elastic[0]);
  EXPECT_EQ(after.overlap[0], before.overlap[0]);
  EXPECT_TRUE(same_bits(after.force[0], before.force[0]));
  EXPECT_EQ(after.row_start, (std::vector<std::uint32_t>{0, 1, 1, 1}));
  // The next force loop ends (0, 2) with what it dissipated, work - elastic, booked once.
  ContactConfig contact;
  contact.sliding_friction = 0.5;
  const MaterialTable materials({MaterialConfig{}}, {contact}, Separation::overlap);
  select_force_kernels(Separation::overlap, true, RollingKind::none).neighbour_forces(s, materials, nb, 1e-5, DashpotVelocity{});
  ContactEvents events;
  EXPECT_EQ(finish_ended_contacts(s, nb, before, &events), before.work[1] - before.elastic[1]);
  CollisionSpectra spectra;
  spectra.record(events);
  EXPECT_EQ(spectra.events(CollisionSpectra::ball_ball), 1u);
  EXPECT_TRUE(nb.left_behind.empty());
}

TEST(NeighbourContacts, AnIdleSlotStartsAsANewContact) {
  State s = three_spheres();
  s.position[1] = Vec3(0.021, 0, 0);  // a candidate (gap 1 mm < skin), not touching
  broadphase::GridBroadphase grid;
  broadphase::CandidatePairs candidates;
  grid.find_pairs(s.position, s.radius, 0.002, candidates);
  PairContacts none;
  none.parts = {true, false, true};
  none.index_rows(s.size());
  NeighbourContacts nb;
  rebuild_neighbours(s, candidates, none, nb);
  EXPECT_TRUE(nb.left_behind.empty());
  ASSERT_EQ(nb.size(), 1u);
  EXPECT_EQ(nb.touching[0], touching_no);
  EXPECT_EQ(nb.list.overlap[0], 0) << "overlap 0 marks the onset at the first evaluation";
  EXPECT_TRUE(nb.list.force[0].isZero(0));
  EXPECT_TRUE(nb.moment[0].isZero(0));
  EXPECT_EQ(nb.list.books[0].impact_energy, -1);
  PairContacts compact;
  std::vector<std::uint32_t> scratch;
  compact_touching(s, nb, compact, scratch);
  EXPECT_EQ(compact.size(), 0u);
}

// The compact path (update_pair_contacts, still step doubling's) is the oracle for how contacts end:
// in one step, in one row, a contact parts but stays a candidate (its release step is booked) and
// another leaves the candidates (it ends without one), around a contact that lasts. The persistent
// path books the same dissipation and the same spectra, bit for bit.
TEST(NeighbourContacts, ContactsEndAsTheCompactPathEndsThem) {
  State s;
  s.add(Vec3(0, 0, 0), Vec3::Zero(), Vec3::Zero(), 0.01, 1, 1, 0);
  s.add(Vec3(0.0195, 0, 0), Vec3(0.1, 0, 0), Vec3::Zero(), 0.01, 1, 1, 0);
  s.add(Vec3(0, 0.0195, 0), Vec3(0, 0.1, 0), Vec3::Zero(), 0.01, 1, 1, 0);
  s.add(Vec3(0, 0, 0.0195), Vec3::Zero(), Vec3(0, 0, 1), 0.01, 1, 1, 0);
  PairContacts before;
  before.parts = {true, false, true};
  before.resize(3);
  for (std::size_t k = 0; k < 3; ++k) {
    before.key[k] = pair_key(s.id[0], s.id[k + 1]);
    before.i[k] = 0;
    before.j[k] = static_cast<ParticleIndex>(k + 1);
    before.tangential_spring[k] = Vec3(0, 0, 1e-6 * static_cast<Real>(k + 1));
    before.mode[k] = 0;
    before.books[k] = {0.3 + 0.1 * static_cast<Real>(k), 0.02, 0.5};
    before.overlap[k] = 5e-4;
    before.work[k] = 0.7 / static_cast<Real>(k + 3);
    before.elastic[k] = 0.01 * static_cast<Real>(k + 1);
    before.force[k] = Vec3(50, 0, 0);
  }
  before.index_rows(s.size());
  // The step: 1 parts within the skin, 2 leaves the candidates, 3 stays in contact.
  s.position[1] = Vec3(0.0205, 0, 0);
  s.position[2] = Vec3(0, 0.03, 0);
  broadphase::GridBroadphase grid;
  broadphase::CandidatePairs candidates;
  grid.find_pairs(s.position, s.radius, 0.002, candidates);
  ASSERT_EQ(candidates.pair_count(), 2u) << "(0, 1) and (0, 3)";
  ContactConfig contact;
  contact.normal_stiffness = 1e5;
  contact.sliding_friction = 0.5;
  const MaterialTable materials({MaterialConfig{}}, {contact}, Separation::overlap);

  PairContacts compact = before;
  ContactWorkspace work;
  CollisionSpectra compact_spectra;
  const Real compact_ended = update_pair_contacts(
      s, candidates, materials, compact, work,
      [&](const PairContacts& old, const std::vector<std::uint64_t>& after) { compact_spectra.record_ended(old, after); });

  NeighbourContacts nb;
  CollisionSpectra persistent_spectra;
  rebuild_neighbours(s, candidates, before, nb);
  const ForceKernels kernels = select_force_kernels(Separation::overlap, true, RollingKind::none);
  kernels.neighbour_forces(s, materials, nb, 1e-5, DashpotVelocity{});
  ContactEvents persistent_events;
  const Real persistent_ended = finish_ended_contacts(s, nb, before, &persistent_events);
  persistent_spectra.record(persistent_events);

  EXPECT_EQ(persistent_ended, compact_ended);
  EXPECT_NE(compact_ended, (before.work[0] - before.elastic[0]) + (before.work[1] - before.elastic[1]))
      << "the contact that parted within the skin has its release step booked";
  EXPECT_EQ(persistent_spectra.events(CollisionSpectra::ball_ball), 2u);
  EXPECT_EQ(persistent_spectra.events(CollisionSpectra::ball_ball), compact_spectra.events(CollisionSpectra::ball_ball));
  EXPECT_EQ(persistent_spectra.dissipated(), compact_spectra.dissipated());
  for (int q = 0; q < CollisionSpectra::quantity_count; ++q)
    for (int b = 0; b < CollisionSpectra::bin_count; ++b)
      EXPECT_EQ(persistent_spectra.energy(CollisionSpectra::ball_ball, CollisionSpectra::Quantity(q), b),
                compact_spectra.energy(CollisionSpectra::ball_ball, CollisionSpectra::Quantity(q), b));
  PairContacts now;
  std::vector<std::uint32_t> scratch;
  compact_touching(s, nb, now, scratch);
  ASSERT_EQ(now.size(), 1u);
  EXPECT_EQ(now.key[0], pair_key(s.id[0], s.id[3]));
  EXPECT_TRUE(nb.left_behind.empty()) << "booked once";
}

// The force loop takes a row a stretch of slots at a time. A large sphere with 40 small ones around it
// holds one row of 40 slots, three stretches: in one step a third of its contacts last (at overlaps
// that differ, the deepest in the middle stretch), a third part within the skin and a third leave the
// candidates, spread over every stretch. The compact path is the oracle: the same ended dissipation,
// spectra, contacts, gathered forces and torques and deepest contact, bit for bit.
TEST(NeighbourContacts, ARowLongerThanOneStretchAgreesWithTheCompactPath) {
  constexpr int small_count = 40;
  const Real big = 0.05, small = 0.01, touching = big + small - 5e-4;
  State s;
  s.add(Vec3::Zero(), Vec3(0.01, -0.02, 0.03), Vec3(1, 2, 3), big, 1, 1, 0);
  std::vector<Vec3> direction;
  for (int k = 0; k < small_count; ++k) {  // a Fibonacci sphere: neighbours 0.03 m apart, no two touch
    const Real z = 1 - (2 * k + 1) / Real(small_count), rho = std::sqrt(1 - z * z), phi = 2.399963229728653 * k;
    direction.push_back(Vec3(rho * std::cos(phi), rho * std::sin(phi), z));
    s.add(touching * direction.back(), 0.05 * direction.back().cross(Vec3::UnitZ()), Vec3(0, 0, k), small, 1, 1, 0);
  }
  PairContacts before;
  before.parts = {true, false, true};
  before.resize(small_count);
  for (int k = 0; k < small_count; ++k) {
    before.key[k] = pair_key(s.id[0], s.id[k + 1]);
    before.i[k] = 0;
    before.j[k] = static_cast<ParticleIndex>(k + 1);
    before.tangential_spring[k] = Vec3(0, 0, 1e-6 * (k % 5));
    before.mode[k] = 0;
    before.books[k] = {0.01 * k, 0.02, 0.5};
    before.overlap[k] = 5e-4;
    before.work[k] = 0.7 / (k + 3);
    before.elastic[k] = 0.001 * (k + 1);
    before.force[k] = Vec3(50, 0, 0);
  }
  before.index_rows(s.size());
  // The step: k % 3 == 0 lasts (deeper with k up to the middle stretch), 1 parts within the skin,
  // 2 leaves the candidates.
  for (int k = 0; k < small_count; ++k) {
    const Real distance = k % 3 == 0 ? touching - 1e-5 * (k < 24 ? k : 48 - k)
                          : k % 3 == 1 ? big + small + 5e-4
                                       : big + small + 0.02;
    s.position[k + 1] = distance * direction[k];
  }
  broadphase::GridBroadphase grid;
  broadphase::CandidatePairs candidates;
  grid.find_pairs(s.position, s.radius, 0.002, candidates);
  ASSERT_EQ(candidates.row_start[1] - candidates.row_start[0], 27u) << "row 0: the lasting and the parting";
  ASSERT_EQ(candidates.pair_count(), 27u);
  ContactConfig contact;
  contact.normal_stiffness = 1e5;
  contact.sliding_friction = 0.5;
  const MaterialTable materials({MaterialConfig{}}, {contact}, Separation::overlap);
  const ForceKernels kernels = select_force_kernels(Separation::overlap, true, RollingKind::none);
  const Real h = 1e-5;
  const WallContacts no_walls;
  const std::vector<std::uint32_t> no_wall_starts(s.size() + 1, 0);

  PairContacts compact = before;
  ContactWorkspace work;
  CollisionSpectra compact_spectra;
  const Real compact_ended = update_pair_contacts(
      s, candidates, materials, compact, work,
      [&](const PairContacts& old, const std::vector<std::uint64_t>& after) { compact_spectra.record_ended(old, after); });
  kernels.pair_forces(s, materials, compact, h, DashpotVelocity{});
  ContactAdjacency adjacency;
  build_pair_adjacency(s.size(), compact, adjacency);
  adjacency.wall_start = no_wall_starts;
  State compact_state = s;
  gather_forces(compact_state, compact, no_walls, adjacency, true, 3);

  NeighbourContacts nb;
  rebuild_neighbours(s, candidates, before, nb);
  kernels.neighbour_forces(s, materials, nb, h, DashpotVelocity{});
  ContactEvents persistent_events;
  const Real persistent_ended = finish_ended_contacts(s, nb, before, &persistent_events);
  CollisionSpectra persistent_spectra;
  persistent_spectra.record(persistent_events);
  State persistent_state = s;
  gather_neighbour_forces(persistent_state, nb, no_walls, no_wall_starts, true, 3);

  EXPECT_EQ(persistent_ended, compact_ended);
  EXPECT_EQ(persistent_spectra.events(CollisionSpectra::ball_ball), 26u) << "13 parted, 13 left the candidates";
  EXPECT_EQ(persistent_spectra.events(CollisionSpectra::ball_ball), compact_spectra.events(CollisionSpectra::ball_ball));
  EXPECT_EQ(persistent_spectra.dissipated(), compact_spectra.dissipated());
  PairContacts now;
  std::vector<std::uint32_t> scratch;
  compact_touching(s, nb, now, scratch);
  ASSERT_EQ(now.size(), 14u);
  EXPECT_EQ(now.key, compact.key);
  std::size_t differ = 0;
  for (std::size_t p = 0; p < s.size(); ++p)
    differ += !same_bits(persistent_state.force[p], compact_state.force[p]) ||
              !same_bits(persistent_state.torque[p], compact_state.torque[p]);
  EXPECT_EQ(differ, 0u) << "particles whose force or torque differ from the compact gather";
  EXPECT_GT(compact_state.torque[0].norm(), 0) << "the tangential springs turn the big sphere";
  const Worst compact_deepest = deepest_contact(s, compact, no_walls);
  const Worst persistent_deepest = deepest_contact(s, nb, no_walls);
  EXPECT_EQ(persistent_deepest.value, compact_deepest.value);
  EXPECT_EQ(persistent_deepest.partner, compact_deepest.partner);
  EXPECT_EQ(compact_deepest.partner, s.id[25]) << "small sphere 24, in the middle stretch";
}

// After a particle is removed the persistent list waits for the next step; the deepest overlap the
// World reports meanwhile comes from the compact list, with valid ids.
TEST(NeighbourContacts, DeepestOverlapBeforeTheNextStepAfterARemoval) {
  const std::unique_ptr<World> world = World::load(scene("dense_bed.toml"), {"run.threads=2"});
  for (int step = 0; step < 5; ++step) ASSERT_EQ(world->advance_sync_interval(), StepStatus::ok);
  const Worst before = world->deepest_overlap();
  ASSERT_GT(before.value, 0);
  ASSERT_TRUE(world->remove_particle(before.particle));
  const Worst after = world->deepest_overlap();
  const Worst compact = deepest_contact(world->state(), world->pair_contacts(), world->wall_contacts());
  EXPECT_EQ(after.value, compact.value);
  EXPECT_EQ(after.particle, compact.particle);
  EXPECT_EQ(after.partner, compact.partner);
  EXPECT_NE(after.particle, before.particle);
  EXPECT_TRUE(world->index_of(after.particle).has_value());
  EXPECT_TRUE(world->index_of(after.partner).has_value());
  EXPECT_EQ(world->advance_sync_interval(), StepStatus::ok);
}

// On the settled bed after some steps: the compact list holds exactly the overlapping pairs (found
// anew by the grid with no skin), and the forces, torques and deepest overlap the World derived
// from its persistent list are those the compact-list routines give, bit for bit.
TEST(NeighbourContacts, WorldAgreesWithTheCompactListOnTheDenseBed) {
  // Re-sorted in memory, so that the lists' orders by id and by slot differ.
  const std::unique_ptr<World> world =
      World::load(scene("dense_bed.toml"), {"run.threads=2", "broadphase.sort_interval=1000"});
  for (int step = 0; step < 60; ++step) ASSERT_EQ(world->advance_sync_interval(), StepStatus::ok);
  const State& s = world->state();
  const PairContacts& pairs = world->pair_contacts();
  ASSERT_GT(pairs.size(), s.size());

  broadphase::GridBroadphase grid;
  broadphase::CandidatePairs touching;
  grid.find_pairs(s.position, s.radius, 0.0, touching);
  std::set<std::uint64_t> expected;
  for (std::size_t a = 0; a < touching.row_count(); ++a)
    for (std::uint32_t q = touching.row_start[a]; q < touching.row_start[a + 1]; ++q) {
      const ParticleIndex b = touching.partner[q];
      const Real reach = s.radius[a] + s.radius[b];
      if ((s.position[a] - s.position[b]).squaredNorm() < reach * reach)
        expected.insert(pair_key(s.id[a], s.id[b]));
    }
  EXPECT_FALSE(s.slots_follow_ids()) << "re-sorted";
  EXPECT_TRUE(std::is_sorted(pairs.i.begin(), pairs.i.end())) << "row order";
  EXPECT_TRUE(keys_ascend_along_rows(pairs));
  for (std::size_t k = 0; k < pairs.size(); ++k) ASSERT_LT(s.id[pairs.i[k]], s.id[pairs.j[k]]);
  EXPECT_EQ(std::set<std::uint64_t>(pairs.key.begin(), pairs.key.end()), expected);

  ContactAdjacency adjacency;
  build_pair_adjacency(s.size(), pairs, adjacency);
  const WallContacts& walls = world->wall_contacts();
  adjacency.wall_start.assign(s.size() + 1, 0);
  for (std::size_t k = 0; k < walls.size(); ++k) ++adjacency.wall_start[walls.particle[k] + 1];
  for (std::size_t p = 0; p < s.size(); ++p) adjacency.wall_start[p + 1] += adjacency.wall_start[p];
  State gathered = s;
  gather_forces(gathered, pairs, walls, adjacency, world->has_rotation(), 3);
  std::size_t differ = 0;
  for (std::size_t p = 0; p < s.size(); ++p)
    differ += !same_bits(gathered.force[p], s.force[p]) || !same_bits(gathered.torque[p], s.torque[p]);
  EXPECT_EQ(differ, 0u) << "particles whose force or torque differ from the compact gather";

  const Worst compact = deepest_contact(s, pairs, walls);
  const Worst persistent = world->deepest_overlap();
  EXPECT_EQ(persistent.value, compact.value);
  EXPECT_EQ(persistent.particle, compact.particle);
  EXPECT_EQ(persistent.partner, compact.partner);
  EXPECT_GT(compact.value, 0);
}

}  // namespace
}  // namespace dem

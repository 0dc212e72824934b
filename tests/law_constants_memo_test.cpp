// LawConstantsMemo (engine/materials.h) and particle kinds (engine/particle_kinds.h): whatever the
// order of the pairs asked for, the memo gives exactly MaterialTable::law_constants of each pair,
// keyed on the inputs' bits or on the particles' kinds; it computes anew whenever any input differs,
// down to the sign of a zero.
#include <gtest/gtest.h>

#include <bit>
#include <cstring>
#include <limits>
#include <vector>

#include "engine/materials.h"
#include "engine/particle_kinds.h"

namespace dem {
namespace {

bool same_bits(const LawConstants& a, const LawConstants& b) { return std::memcmp(&a, &b, sizeof a) == 0; }

MaterialTable two_material_table() {
  std::vector<MaterialConfig> materials{{"steel", 7800}, {"rock", 2700}};
  ContactConfig all;  // every pair: damping ratios, so m*, m_t and I* all enter the constants
  all.normal_stiffness = 2e5;
  all.normal_damping = {DampingKind::damping_ratio, 0.3};
  all.tangential_damping = {DampingKind::damping_ratio, 0.2};
  all.sliding_friction = 0.5;
  all.rolling_friction = 0.05;
  ContactConfig steel_rock = all;
  steel_rock.material_a = "steel";
  steel_rock.material_b = "rock";
  steel_rock.normal_stiffness = 4e5;
  steel_rock.normal_damping = {DampingKind::gamma, 50};
  return MaterialTable(materials, {all, steel_rock}, Separation::force_zero);
}

template <bool Friction, bool Rolling>
LawConstants table_constants(const MaterialTable& table, const LawInputs& p) {
  return table.law_constants<Friction, Rolling>(p);
}

template <bool Friction, bool Rolling>
void expect_memo_matches_table(const MaterialTable& table, const std::vector<LawInputs>& pairs) {
  LawConstantsMemo<LawInputs> memo;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const LawInputs& p = pairs[k];
    const LawConstants expected = table_constants<Friction, Rolling>(table, p);
    const LawConstants& got = memo.get(p, [&] { return table_constants<Friction, Rolling>(table, p); });
    EXPECT_TRUE(same_bits(got, expected)) << "pair " << k << " (Friction " << Friction << ", Rolling " << Rolling
                                          << "): k_n " << got.k_n << " against " << expected.k_n << ", c_n " << got.c_n
                                          << " against " << expected.c_n;
  }
}

TEST(LawConstantsMemo, GivesTheTablesConstantsForEveryPairInAnyOrder) {
  const MaterialTable table = two_material_table();
  const std::uint16_t same = table.pair_class(0, 0), mixed = table.pair_class(0, 1);
  ASSERT_NE(same, mixed);
  const Real inf = std::numeric_limits<Real>::infinity();
  // A ball of radius 5 mm and one of 2 mm (inverse masses and inertias of steel spheres), a wall.
  const Real m5 = 1 / (7800 * 4.0 / 3.0 * 3.14159 * 1.25e-7), i5 = m5 / (0.4 * 25e-6);
  const Real m2 = 1 / (7800 * 4.0 / 3.0 * 3.14159 * 8e-9), i2 = m2 / (0.4 * 4e-6);
  const LawInputs big_big{same, m5, i5, 0.005, m5, i5, 0.005};
  const LawInputs big_small{same, m5, i5, 0.005, m2, i2, 0.002};
  const LawInputs big_small_mixed{mixed, m5, i5, 0.005, m2, i2, 0.002};
  const LawInputs small_small{same, m2, i2, 0.002, m2, i2, 0.002};
  const LawInputs big_wall{same, m5, i5, 0.005, 0, 0, inf};
  const LawInputs small_wall{mixed, m2, i2, 0.002, 0, 0, inf};
  // Repeats (the memo's hits) between changes of every single input (its misses).
  std::vector<LawInputs> pairs{big_big,   big_big,     big_small, big_small,       big_small_mixed,
                                big_big,   small_small, big_wall,  big_wall,        small_wall,
                                big_small, big_big,     big_small_mixed, small_small, big_big};
  LawInputs changed = big_big;
  for (Real LawInputs::*field : {&LawInputs::inv_m_i, &LawInputs::inv_i_i, &LawInputs::r_i, &LawInputs::inv_m_j,
                                  &LawInputs::inv_i_j, &LawInputs::r_j}) {
    changed = big_big;
    changed.*field *= 1.5;
    pairs.push_back(changed);
    pairs.push_back(big_big);
  }
  expect_memo_matches_table<true, true>(table, pairs);
  expect_memo_matches_table<true, false>(table, pairs);
  expect_memo_matches_table<false, false>(table, pairs);
}

// +0 and -0 compare equal as numbers but may give different constants (1 / +0 against 1 / -0): the
// memo tells them apart by their bits.
TEST(LawConstantsMemo, TellsASignedZeroFromAnUnsignedOne) {
  const MaterialTable table = two_material_table();
  const std::uint16_t same = table.pair_class(0, 0);
  const Real inf = std::numeric_limits<Real>::infinity();
  const LawInputs plus{same, 0.0, 0.0, 0.005, 0.0, 0.0, inf};
  const LawInputs minus{same, -0.0, -0.0, 0.005, -0.0, -0.0, inf};
  LawConstantsMemo<LawInputs> memo;
  const LawConstants first = memo.get(plus, [&] { return table_constants<true, true>(table, plus); });
  const LawConstants second = memo.get(minus, [&] { return table_constants<true, true>(table, minus); });
  const LawConstants expected = table_constants<true, true>(table, minus);
  EXPECT_TRUE(same_bits(second, expected));
  EXPECT_FALSE(same_bits(first, second)) << "m* = 1 / (+0) and 1 / (-0) differ in sign, so the constants do";
}

// Particles of eight kinds: two ball sizes of steel, a ball of rock, copies of the big steel ball
// that differ in one value each (inverse mass, inverse inertia, radius), and two fixed ones whose
// inverse mass and inertia are +0 and -0. Laid out in a mixed order, more kinds than the numbering
// keeps in view at once, with the copy of another inverse inertia right after the ball it copies.
State mixed_particles(const MaterialTable& table) {
  const Real m5 = 1 / (7800 * 4.0 / 3.0 * 3.14159 * 1.25e-7), i5 = m5 / (0.4 * 25e-6);
  const Real m2 = 1 / (7800 * 4.0 / 3.0 * 3.14159 * 8e-9), i2 = m2 / (0.4 * 4e-6);
  const Real r5 = 1 / (2700 * 4.0 / 3.0 * 3.14159 * 1.25e-7), ri5 = r5 / (0.4 * 25e-6);
  const std::uint16_t steel = static_cast<std::uint16_t>(table.find("steel"));
  const std::uint16_t rock = static_cast<std::uint16_t>(table.find("rock"));
  struct Kind {
    Real r, inv_m, inv_i;
    std::uint16_t material;
  };
  const std::vector<Kind> kinds{{0.005, m5, i5, steel},       {0.002, m2, i2, steel},  {0.005, r5, ri5, rock},
                                {0.005, m5 * 1.5, i5, steel}, {0.005, m5, i5 * 1.5, steel}, {0.0051, m5, i5, steel},
                                {0.005, 0.0, 0.0, steel},     {0.005, -0.0, -0.0, steel}};
  const std::vector<int> order{0, 0, 1, 0, 2, 2, 1, 3, 0, 4, 5, 6, 7, 0, 1, 2, 0, 0, 7, 6, 3, 5, 4, 1, 1, 0};
  State s;
  for (std::size_t q = 0; q < order.size(); ++q) {
    const Kind& k = kinds[order[q]];
    s.add(Vec3(0.01 * q, 0, 0), Vec3::Zero(), Vec3::Zero(), k.r, k.inv_m, k.inv_i, k.material);
  }
  return s;
}

bool same_kind_bits(const State& s, std::size_t p, std::size_t q) {
  const auto bits = [](Real x) { return std::bit_cast<std::uint64_t>(x); };
  return s.material[p] == s.material[q] && bits(s.inv_mass[p]) == bits(s.inv_mass[q]) &&
         bits(s.inv_inertia[p]) == bits(s.inv_inertia[q]) && bits(s.radius[p]) == bits(s.radius[q]);
}

TEST(ParticleKinds, ParticlesOfOneKindAreAlikeBitForBit) {
  const MaterialTable table = two_material_table();
  const State s = mixed_particles(table);
  std::vector<std::uint32_t> kind;
  assign_particle_kinds(s, kind);
  ASSERT_EQ(kind.size(), s.size());
  for (std::size_t p = 0; p < s.size(); ++p)
    for (std::size_t q = 0; q < s.size(); ++q)
      if (kind[p] == kind[q]) {
        EXPECT_TRUE(same_kind_bits(s, p, q)) << "particles " << p << " and " << q;
      }
  // Alike neighbours in memory, and the few kinds of a charge, share a kind (the memo's hits).
  EXPECT_EQ(kind[0], kind[1]);
  EXPECT_EQ(kind[0], kind[3]);
  EXPECT_EQ(kind[2], kind[6]);
  EXPECT_EQ(kind[24], kind[23]);
  EXPECT_NE(kind[11], kind[12]) << "an inverse mass of +0 and one of -0";
}

// The force loop over a persistent list keys the memo on the two particles' kinds: over every pair of
// the mixed particles in row order, it gives the table's constants, bit for bit.
TEST(ParticleKinds, AMemoKeyedOnKindsGivesTheTablesConstants) {
  const MaterialTable table = two_material_table();
  const State s = mixed_particles(table);
  std::vector<std::uint32_t> kind;
  assign_particle_kinds(s, kind);
  LawConstantsMemo<std::uint64_t> memo;
  std::size_t computed = 0;
  for (std::size_t i = 0; i < s.size(); ++i)
    for (std::size_t j = i + 1; j < s.size(); ++j) {
      const LawInputs p{table.pair_class(s.material[i], s.material[j]), s.inv_mass[i], s.inv_inertia[i], s.radius[i],
                         s.inv_mass[j], s.inv_inertia[j], s.radius[j]};
      const std::uint64_t key = std::uint64_t{kind[i]} << 32 | kind[j];
      const LawConstants& got = memo.get(key, [&] {
        ++computed;
        return table_constants<true, true>(table, p);
      });
      EXPECT_TRUE(same_bits(got, table_constants<true, true>(table, p))) << "pair " << i << ", " << j;
    }
  EXPECT_LT(computed, s.size() * (s.size() - 1) / 2) << "repeated kinds reuse the constants";
}

}  // namespace
}  // namespace dem

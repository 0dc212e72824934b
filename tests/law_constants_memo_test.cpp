// LawConstantsMemo (engine/materials.h): whatever the order of the pairs asked for, it gives exactly
// MaterialTable::law_constants of each pair, and it computes anew whenever any input differs, down to
// the sign of a zero.
#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <vector>

#include "engine/materials.h"

namespace dem {
namespace {

// One pair's inputs, as the force loops pass them.
struct PairInputs {
  std::uint16_t pair_class;
  Real inv_m_i, inv_i_i, r_i, inv_m_j, inv_i_j, r_j;
};

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
void expect_memo_matches_table(const MaterialTable& table, const std::vector<PairInputs>& pairs) {
  LawConstantsMemo<Friction, Rolling> memo;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const PairInputs& p = pairs[k];
    const LawConstants expected =
        table.law_constants<Friction, Rolling>(p.pair_class, p.inv_m_i, p.inv_i_i, p.r_i, p.inv_m_j, p.inv_i_j, p.r_j);
    const LawConstants& got = memo.get(table, p.pair_class, p.inv_m_i, p.inv_i_i, p.r_i, p.inv_m_j, p.inv_i_j, p.r_j);
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
  const PairInputs big_big{same, m5, i5, 0.005, m5, i5, 0.005};
  const PairInputs big_small{same, m5, i5, 0.005, m2, i2, 0.002};
  const PairInputs big_small_mixed{mixed, m5, i5, 0.005, m2, i2, 0.002};
  const PairInputs small_small{same, m2, i2, 0.002, m2, i2, 0.002};
  const PairInputs big_wall{same, m5, i5, 0.005, 0, 0, inf};
  const PairInputs small_wall{mixed, m2, i2, 0.002, 0, 0, inf};
  // Repeats (the memo's hits) between changes of every single input (its misses).
  std::vector<PairInputs> pairs{big_big,   big_big,     big_small, big_small,       big_small_mixed,
                                big_big,   small_small, big_wall,  big_wall,        small_wall,
                                big_small, big_big,     big_small_mixed, small_small, big_big};
  PairInputs changed = big_big;
  for (Real PairInputs::*field : {&PairInputs::inv_m_i, &PairInputs::inv_i_i, &PairInputs::r_i, &PairInputs::inv_m_j,
                                  &PairInputs::inv_i_j, &PairInputs::r_j}) {
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
  const PairInputs plus{same, 0.0, 0.0, 0.005, 0.0, 0.0, inf};
  const PairInputs minus{same, -0.0, -0.0, 0.005, -0.0, -0.0, inf};
  LawConstantsMemo<true, true> memo;
  const LawConstants first = memo.get(table, plus.pair_class, plus.inv_m_i, plus.inv_i_i, plus.r_i, plus.inv_m_j,
                                      plus.inv_i_j, plus.r_j);
  const LawConstants second = memo.get(table, minus.pair_class, minus.inv_m_i, minus.inv_i_i, minus.r_i,
                                       minus.inv_m_j, minus.inv_i_j, minus.r_j);
  const LawConstants expected = table.law_constants<true, true>(minus.pair_class, minus.inv_m_i, minus.inv_i_i,
                                                                 minus.r_i, minus.inv_m_j, minus.inv_i_j, minus.r_j);
  EXPECT_TRUE(same_bits(second, expected));
  EXPECT_FALSE(same_bits(first, second)) << "m* = 1 / (+0) and 1 / (-0) differ in sign, so the constants do";
}

}  // namespace
}  // namespace dem

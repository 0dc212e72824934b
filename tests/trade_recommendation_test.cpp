// The recommendation of `dem trade` on hand-made rows (engine/cli/trade_recommendation.h), no
// simulation run:
//  - the chosen row is the cheapest within the threshold, not the cheapest overall nor the most accurate;
//  - ties in particle-steps go to the smaller error, then to the earlier row;
//  - diverged rows never qualify, however small their recorded error;
//  - when nothing qualifies, the most accurate finished row is named;
//  - a target replaces the noise floor; with neither, the criterion is none and nothing is chosen;
//  - --target items are parsed, and bad ones rejected naming the item and the valid metrics.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "engine/cli/trade_recommendation.h"
#include "engine/input_error.h"

namespace {

using namespace dem::cli::trade;

constexpr double inf = std::numeric_limits<double>::infinity();
constexpr double no_floor = std::numeric_limits<double>::quiet_NaN();

CostedRow fixed_row(double dt, std::uint64_t particle_steps, double error, bool finished = true) {
  return {"fixed", dt, std::nan(""), particle_steps, 0.1, finished, {error}};
}

CostedRow doubling_row(double tolerance, std::uint64_t particle_steps, double error, bool finished = true) {
  return {"doubling", 1e-2, tolerance, particle_steps, 0.1, finished, {error}};
}

TEST(TradeRecommendation, ChoosesTheCheapestRowWithinTheNoiseFloorNotTheCheapestRow) {
  const std::vector<CostedRow> rows = {
      fixed_row(4e-3, 100, 5e-3),     // cheapest, outside the floor
      fixed_row(2e-3, 200, 8e-5),     // within
      fixed_row(1e-3, 400, 1e-6),     // within, dearer, more accurate
      doubling_row(1e-2, 150, 9e-5),  // within and the cheapest that is
      doubling_row(1e-3, 300, 2e-6),
  };
  const Choice c = recommend(rows, 0, 1e-4, std::nullopt);
  EXPECT_EQ(c.criterion, Criterion::noise);
  EXPECT_DOUBLE_EQ(c.threshold, 1e-4);
  EXPECT_EQ(c.chosen, std::optional<std::size_t>(3));
  EXPECT_EQ(c.cheapest_fixed, std::optional<std::size_t>(1));
  EXPECT_EQ(c.cheapest_doubling, std::optional<std::size_t>(3));
  EXPECT_EQ(c.most_accurate, std::optional<std::size_t>(2));
}

TEST(TradeRecommendation, AnErrorEqualToTheFloorQualifies) {
  // The table marks errors at or below the floor with `~`; the recommendation agrees.
  const std::vector<CostedRow> rows = {fixed_row(2e-3, 200, 2e-4), fixed_row(1e-3, 400, 1e-4)};
  EXPECT_EQ(recommend(rows, 0, 2e-4, std::nullopt).chosen, std::optional<std::size_t>(0));
  EXPECT_EQ(recommend(rows, 0, 1.5e-4, std::nullopt).chosen, std::optional<std::size_t>(1));
}

TEST(TradeRecommendation, ATieInParticleStepsGoesToTheSmallerErrorThenTheEarlierRow) {
  const std::vector<CostedRow> rows = {fixed_row(2e-3, 200, 5e-5), doubling_row(1e-2, 200, 3e-5),
                                       doubling_row(1e-3, 200, 3e-5), fixed_row(1e-3, 400, 1e-6)};
  const Choice c = recommend(rows, 0, 1e-4, std::nullopt);
  EXPECT_EQ(c.chosen, std::optional<std::size_t>(1));
  EXPECT_EQ(c.cheapest_doubling, std::optional<std::size_t>(1));
  EXPECT_EQ(c.cheapest_fixed, std::optional<std::size_t>(0));
  // The same rows with equal errors: the first listed wins.
  const std::vector<CostedRow> same = {doubling_row(1e-2, 200, 3e-5), fixed_row(2e-3, 200, 3e-5)};
  EXPECT_EQ(recommend(same, 0, 1e-4, std::nullopt).chosen, std::optional<std::size_t>(0));
}

TEST(TradeRecommendation, DivergedRowsAreNeverChosen) {
  // A diverged row's errors are infinite in trade.csv; here a small one is recorded to show that the
  // status alone rules it out.
  const std::vector<CostedRow> rows = {fixed_row(8e-3, 50, 1e-9, false), fixed_row(4e-3, 100, inf, false),
                                       doubling_row(1e-1, 60, 1e-9, false), fixed_row(2e-3, 200, 5e-5)};
  const Choice c = recommend(rows, 0, 1e-4, std::nullopt);
  EXPECT_EQ(c.chosen, std::optional<std::size_t>(3));
  EXPECT_EQ(c.cheapest_fixed, std::optional<std::size_t>(3));
  EXPECT_EQ(c.cheapest_doubling, std::nullopt);
  EXPECT_EQ(c.most_accurate, std::optional<std::size_t>(3));
  // With a target every error meets, still no diverged row.
  EXPECT_EQ(recommend(rows, 0, no_floor, 1.0).chosen, std::optional<std::size_t>(3));
}

TEST(TradeRecommendation, WhenNothingQualifiesTheMostAccurateRowIsNamed) {
  const std::vector<CostedRow> rows = {fixed_row(4e-3, 100, 5e-3), doubling_row(1e-3, 300, 2e-4),
                                       fixed_row(2e-3, 200, 8e-4), fixed_row(1e-3, 400, inf, false)};
  const Choice c = recommend(rows, 0, 1e-5, std::nullopt);
  EXPECT_EQ(c.criterion, Criterion::noise);
  EXPECT_EQ(c.chosen, std::nullopt);
  EXPECT_EQ(c.cheapest_fixed, std::nullopt);
  EXPECT_EQ(c.cheapest_doubling, std::nullopt);
  EXPECT_EQ(c.most_accurate, std::optional<std::size_t>(1));
  // No row finished: nothing to name.
  const std::vector<CostedRow> diverged = {fixed_row(4e-3, 100, inf, false)};
  EXPECT_EQ(recommend(diverged, 0, 1e-5, std::nullopt).most_accurate, std::nullopt);
}

TEST(TradeRecommendation, ATargetReplacesTheNoiseFloor) {
  const std::vector<CostedRow> rows = {fixed_row(4e-3, 100, 5e-3), fixed_row(2e-3, 200, 8e-4),
                                       doubling_row(1e-3, 300, 1e-6)};
  // Looser than the floor: a cheaper row.
  Choice c = recommend(rows, 0, 1e-5, 1e-3);
  EXPECT_EQ(c.criterion, Criterion::target);
  EXPECT_DOUBLE_EQ(c.threshold, 1e-3);
  EXPECT_EQ(c.chosen, std::optional<std::size_t>(1));
  // Tighter than the floor: a dearer row.
  c = recommend(rows, 0, 1e-3, 1e-5);
  EXPECT_EQ(c.criterion, Criterion::target);
  EXPECT_EQ(c.chosen, std::optional<std::size_t>(2));
  // A target of 0 asks for the reference itself: nothing meets it.
  EXPECT_EQ(recommend(rows, 0, 1e-3, 0.0).chosen, std::nullopt);
}

TEST(TradeRecommendation, WithoutAFloorOrATargetItNeedsATarget) {
  const std::vector<CostedRow> rows = {fixed_row(4e-3, 100, 5e-3), fixed_row(2e-3, 200, 8e-4)};
  for (double absent_floor : {no_floor, inf}) {
    const Choice c = recommend(rows, 0, absent_floor, std::nullopt);
    EXPECT_EQ(c.criterion, Criterion::none);
    EXPECT_STREQ(criterion_name(c.criterion), "none");
    EXPECT_EQ(c.chosen, std::nullopt);
    EXPECT_EQ(c.cheapest_fixed, std::nullopt);
  }
  EXPECT_EQ(recommend(rows, 0, no_floor, 1e-3).chosen, std::optional<std::size_t>(1));
}

TEST(TradeRecommendation, EachMetricIsJudgedByItsOwnColumn) {
  std::vector<CostedRow> rows = {fixed_row(4e-3, 100, 1e-6), fixed_row(2e-3, 200, 1e-6)};
  rows[0].errors.push_back(5e-2);  // second metric: only the dearer row is within 1e-3
  rows[1].errors.push_back(1e-4);
  EXPECT_EQ(recommend(rows, 0, 1e-3, std::nullopt).chosen, std::optional<std::size_t>(0));
  EXPECT_EQ(recommend(rows, 1, 1e-3, std::nullopt).chosen, std::optional<std::size_t>(1));
}

const std::vector<std::string> columns = {"dissipated_energy", "bed_height", "kinetic_energy"};

TEST(TradeTargets, ParsesMetricEqualsValueItems) {
  const auto targets = parse_targets({"bed_height=1e-3", " kinetic_energy = 0 "}, columns);
  ASSERT_EQ(targets.size(), 2u);
  EXPECT_DOUBLE_EQ(targets.at("bed_height"), 1e-3);
  EXPECT_DOUBLE_EQ(targets.at("kinetic_energy"), 0);
  EXPECT_TRUE(parse_targets({}, columns).empty());
}

/// The message of the InputError that parse_targets throws for `items` (empty when none).
std::string rejection(const std::vector<std::string>& items) {
  try {
    parse_targets(items, columns);
  } catch (const dem::InputError& e) {
    return e.what();
  }
  return "";
}

TEST(TradeTargets, BadItemsAreRejectedNamingTheItemAndTheValidMetrics) {
  const std::string valid = "dissipated_energy, bed_height, kinetic_energy";
  std::string m = rejection({"bed_hight=1e-3"});
  EXPECT_NE(m.find("--target"), std::string::npos) << m;
  EXPECT_NE(m.find("unknown metric 'bed_hight'"), std::string::npos) << m;
  EXPECT_NE(m.find(valid), std::string::npos) << m;
  m = rejection({"bed_height=abc"});
  EXPECT_NE(m.find("'bed_height=abc'"), std::string::npos) << m;
  EXPECT_NE(m.find("'abc' is not a finite number"), std::string::npos) << m;
  m = rejection({"bed_height=-1e-3"});
  EXPECT_NE(m.find("'-1e-3' is negative"), std::string::npos) << m;
  m = rejection({"bed_height"});
  EXPECT_NE(m.find("no '='"), std::string::npos) << m;
  EXPECT_NE(m.find(valid), std::string::npos) << m;
  m = rejection({"bed_height=inf"});
  EXPECT_NE(m.find("not a finite number"), std::string::npos) << m;
  m = rejection({"bed_height=1e-3", "bed_height=2e-3"});
  EXPECT_NE(m.find("a second target for bed_height"), std::string::npos) << m;
}

}  // namespace

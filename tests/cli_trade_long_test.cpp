// `dem trade` on the shipped mills (ctest label `long`): each fixed step and a step-doubling run finish,
// and the power draw and the collision spectrum are measured against a reference with a noise floor
// from perturbed references. mill_2d over its first 0.5 s (a few minutes on 2 cores); mill_3d over its
// first 0.3 s, while the charge falls in (about an hour on 2 cores). The mill trade tables of docs/mills.md
// come from the same commands with longer windows.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "tests/cli_trade_support.h"

namespace {

using namespace dem::test::trade_cli;

void expect_mill_trade(const std::string& args, std::size_t settings) {
  TempDir dir;
  const Result r = trade(args + " --no-plot --quiet --out " + dir.path().string(), dir);
  ASSERT_EQ(r.code, 0) << r.err;
  const Csv csv = read_csv(dir.path() / "trade.csv");
  ASSERT_EQ(csv.rows.size(), settings);
  for (std::size_t row = 0; row < settings; ++row) {
    SCOPED_TRACE(csv.rows[row].at("control") + " " + csv.rows[row].at("dt") + " " + csv.rows[row].at("tolerance"));
    EXPECT_EQ(csv.rows[row].at("status"), "ok");
    for (const char* metric : {"power_draw", "collision_spectrum"}) {
      const double error = csv.number(row, std::string(metric) + "_error");
      const double noise = csv.number(row, std::string(metric) + "_noise");
      EXPECT_TRUE(std::isfinite(error)) << metric;
      EXPECT_TRUE(std::isfinite(noise) && noise > 0) << metric;
    }
  }
}

TEST(CliTradeLong, Mill2dPowerDrawAndSpectrumUnderBothControls) {
  expect_mill_trade("scenes/mill_2d.toml --fixed 4e-5,8e-5 --tol 1e-2 --until 0.5 --threads 2", 3);
}

TEST(CliTradeLong, Mill3dPowerDrawAndSpectrumUnderBothControls) {
  expect_mill_trade("scenes/mill_3d.toml --fixed 6e-5,1.2e-4 --tol 1e-2 --until 0.3 --threads 2", 3);
}

}  // namespace

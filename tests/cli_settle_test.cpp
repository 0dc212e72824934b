// The settle workflow through the program: a run stops once the kinetic energy is below
// run.stop_kinetic_energy and writes the settled particles as CSV, which loads back as a valid bed.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "engine/particle_csv.h"

namespace {

TEST(CliSettle, StopsWhenSettledAndWritesALoadableBed) {
  const auto out = std::filesystem::temp_directory_path() / ("dem_settle_" + std::to_string(::getpid()));
  std::filesystem::remove_all(out);
  const std::string command = std::string(DEM_PROGRAM) + " run " + DEM_SOURCE_DIR +
                              "/tests/scenes/settle_small.toml --quiet --out " + out.string();
  ASSERT_EQ(std::system(command.c_str()), 0) << command;

  std::ifstream summary(out / "summary.json");
  const std::string text((std::istreambuf_iterator<char>(summary)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"stop_reason\": \"kinetic energy below run.stop_kinetic_energy\""), std::string::npos)
      << "the run must stop by the kinetic-energy criterion, not at run.until";

  const auto bed = dem::read_particle_csv((out / "settled.csv").string());
  ASSERT_EQ(bed.size(), 200u);
  double max_overlap_ratio = 0;
  for (std::size_t a = 0; a < bed.size(); ++a) {
    const auto& p = bed[a];
    EXPECT_LT(p.velocity.norm(), 1e-3) << "particle " << a << " is not at rest";
    // Inside the box [0, 0.06]^2 x [0, 0.1] up to the contact overlap, and resting in its lower half.
    EXPECT_GE(p.position.minCoeff(), p.radius * 0.99);
    EXPECT_LE(p.position.x(), 0.06 - p.radius * 0.99);
    EXPECT_LE(p.position.y(), 0.06 - p.radius * 0.99);
    EXPECT_LE(p.position.z(), 0.05);
    for (std::size_t b = a + 1; b < bed.size(); ++b) {
      const double overlap = p.radius + bed[b].radius - (p.position - bed[b].position).norm();
      max_overlap_ratio = std::max(max_overlap_ratio, overlap / std::min(p.radius, bed[b].radius));
    }
  }
  // A bed that loads under the default max_initial_overlap of 1% of the smaller radius.
  EXPECT_LT(max_overlap_ratio, 0.01);
  EXPECT_GT(max_overlap_ratio, 0.0) << "a settled bed has contacts";
  std::filesystem::remove_all(out);
}

}  // namespace

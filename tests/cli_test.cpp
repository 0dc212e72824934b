// The `dem` program from the outside: it is run through std::system as a user would run it, and only its
// exit code, its messages and the files it writes are looked at.
//  - every scene in tests/scenes/bad/ is rejected by `dem check` with exit code 2, naming the file, line,
//    column and field its header comments state; every scene in scenes/ passes `dem check`;
//  - `--set` overrides reach the run (checked in the outputs), unknown paths are rejected;
//  - the seed slope (docs/physics.md 8.8, engine variant) against the oracle table, read from series.csv;
//  - series.csv, walls.csv, summary.json and the VTK files have the documented shape (docs/design.md, Outputs);
//  - exit codes 2 (bad input) and 3 (divergence); the state hash does not depend on --threads.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "tests/cli_support.h"

namespace {

namespace fs = std::filesystem;

const fs::path source_dir{DEM_SOURCE_DIR};
const fs::path bad_dir = source_dir / "tests" / "scenes" / "bad";

// Running the program: tests/cli_support.h

using dem::test::cli::read_text;
using dem::test::cli::Result;
using dem::test::cli::run_dem;
using dem::test::cli::TempDir;

// ---------------------------------------------------------------------------------------------------
// Reading the outputs: CSV, JSON (tests/cli_support.h), a tiny XML attribute scan

struct Csv {
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;

  int column(const std::string& name) const {
    const auto it = std::find(columns.begin(), columns.end(), name);
    return it == columns.end() ? -1 : static_cast<int>(it - columns.begin());
  }
  double at(std::size_t row, const std::string& name) const { return rows.at(row).at(static_cast<std::size_t>(column(name))); }
};

std::vector<std::string> split_commas(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  std::istringstream in(line);
  while (std::getline(in, cell, ',')) cells.push_back(cell);
  return cells;
}

Csv read_csv(const fs::path& path) {
  Csv csv;
  std::ifstream in(path);
  std::string line;
  if (!std::getline(in, line)) return csv;
  csv.columns = split_commas(line);
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    std::vector<double> row;
    for (const std::string& cell : split_commas(line)) row.push_back(std::strtod(cell.c_str(), nullptr));
    csv.rows.push_back(std::move(row));
  }
  return csv;
}

using dem::test::cli::Json;
using dem::test::cli::read_json;

/// Values of attribute `name` in every element `<tag ...>` of `xml`, in order.
std::vector<std::string> xml_attributes(const std::string& xml, const std::string& tag, const std::string& name) {
  std::vector<std::string> values;
  const std::regex element("<" + tag + R"(\b([^>]*)>)");
  const std::regex attribute(R"(\b)" + name + R"(\s*=\s*"([^"]*)\")");
  for (auto it = std::sregex_iterator(xml.begin(), xml.end(), element); it != std::sregex_iterator(); ++it) {
    const std::string attributes = (*it)[1];
    std::smatch m;
    if (std::regex_search(attributes, m, attribute)) values.push_back(m[1]);
  }
  return values;
}

// ---------------------------------------------------------------------------------------------------
// The corpus of malformed scenes: every file states what the error must contain.

struct BadScene {
  fs::path path;
  std::string expect, field, file;
  int line = 0;  // 0: any positive line
};

std::vector<BadScene> bad_scenes() {
  std::vector<BadScene> scenes;
  if (!fs::exists(bad_dir)) return scenes;
  for (const auto& entry : fs::directory_iterator(bad_dir)) {
    if (entry.path().extension() != ".toml") continue;
    BadScene s;
    s.path = entry.path();
    std::ifstream in(s.path);
    std::string line;
    while (std::getline(in, line) && line.rfind("#", 0) == 0) {
      auto take = [&](const std::string& tag, std::string& into) {
        if (line.rfind(tag, 0) == 0) into = line.substr(tag.size());
      };
      std::string number;
      take("# expect: ", s.expect);
      take("# field: ", s.field);
      take("# file: ", s.file);
      take("# line: ", number);
      if (!number.empty()) s.line = std::stoi(number);
    }
    scenes.push_back(s);
  }
  std::sort(scenes.begin(), scenes.end(), [](const BadScene& a, const BadScene& b) { return a.path < b.path; });
  return scenes;
}

void PrintTo(const BadScene& s, std::ostream* os) { *os << s.path.filename().string(); }

class BadSceneTest : public ::testing::TestWithParam<BadScene> {};

TEST(BadSceneCorpus, HasAtLeastFortyScenesEachStatingItsError) {
  const auto scenes = bad_scenes();
  EXPECT_GE(scenes.size(), 40u);
  for (const BadScene& s : scenes) {
    EXPECT_FALSE(s.expect.empty()) << s.path << " has no '# expect:' line";
    EXPECT_FALSE(s.field.empty()) << s.path << " has no '# field:' line ('-' when the error names none)";
  }
}

TEST_P(BadSceneTest, CheckExitsTwoNamingFileLineColumnAndField) {
  const BadScene& s = GetParam();
  const TempDir tmp;
  const Result r = run_dem({"check", s.path.string()}, tmp.path());
  ASSERT_EQ(r.code, 2) << "stderr: " << r.err;  // exactly 2: bad input, never a crash
  EXPECT_NE(r.err.find(s.expect), std::string::npos) << "expected '" << s.expect << "' in: " << r.err;
  if (s.field != "-") {
    EXPECT_NE(r.err.find("'" + s.field + "'"), std::string::npos) << "field '" << s.field << "' in: " << r.err;
  }
  // file:line:column, the file being the scene or, for a particle CSV, that file (relative to the scene).
  const std::string file = s.file.empty() ? s.path.string() : (s.path.parent_path() / s.file).string();
  const auto at = r.err.find(file + ":");
  ASSERT_NE(at, std::string::npos) << "no '" << file << ":line:column' in: " << r.err;
  std::smatch m;
  const std::string rest = r.err.substr(at + file.size());
  ASSERT_TRUE(std::regex_search(rest, m, std::regex(R"(^:(\d+):(\d+): )"))) << "no line:column after the file in: " << r.err;
  const int line = std::stoi(m[1]), column = std::stoi(m[2]);
  EXPECT_GT(line, 0);
  EXPECT_GT(column, 0);
  if (s.line > 0) {
    EXPECT_EQ(line, s.line) << r.err;
  }
}

INSTANTIATE_TEST_SUITE_P(Corpus, BadSceneTest, ::testing::ValuesIn(bad_scenes()),
                         [](const ::testing::TestParamInfo<BadScene>& p) { return p.param.path.stem().string(); });

TEST(Check, EveryShippedSceneIsValid) {
  const TempDir tmp;
  int count = 0;
  for (const auto& entry : fs::directory_iterator(source_dir / "scenes")) {
    if (entry.path().extension() != ".toml") continue;
    ++count;
    const Result r = run_dem({"check", entry.path().string()}, tmp.path());
    EXPECT_EQ(r.code, 0) << entry.path() << ": " << r.err;
    EXPECT_NE(r.out.find("check: valid"), std::string::npos) << entry.path() << ": " << r.out;
  }
  EXPECT_GE(count, 2);
}

TEST(ExitCodes, MissingSceneFileIsBadInput) {
  const TempDir tmp;
  const std::string missing = (tmp.path() / "no_such_scene.toml").string();
  Result r = run_dem({"check", missing}, tmp.path());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find(missing), std::string::npos) << r.err;
  r = run_dem({"run", missing, "--out", (tmp.path() / "out").string(), "--quiet"}, tmp.path());
  EXPECT_EQ(r.code, 2);
}

TEST(ExitCodes, BadSceneAndBadCommandLineAreBadInputForRunToo) {
  const TempDir tmp;
  Result r = run_dem({"run", (bad_dir / "dt_zero.toml").string(), "--out", (tmp.path() / "out").string(), "--quiet"},
                     tmp.path());
  EXPECT_EQ(r.code, 2) << r.err;
  r = run_dem({"run"}, tmp.path());
  EXPECT_EQ(r.code, 2);
  r = run_dem({"frobnicate"}, tmp.path());
  EXPECT_EQ(r.code, 2);
}

TEST(Version, PrintsNameAndVersion) {
  const TempDir tmp;
  const Result r = run_dem({"--version"}, tmp.path());
  EXPECT_EQ(r.code, 0);
  EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(^dem \d+\.\d+\.\d+)"))) << r.out;
}

// ---------------------------------------------------------------------------------------------------
// --set

const std::string seed_slope = (source_dir / "scenes" / "seed_slope.toml").string();
const std::string seed_slope_2d = (source_dir / "scenes" / "seed_slope_2d.toml").string();
const std::string head_on = (source_dir / "scenes" / "head_on.toml").string();

Result run_scene(const std::string& scene, const fs::path& out, std::vector<std::string> extra) {
  std::vector<std::string> args{"run", scene, "--out", out.string(), "--quiet"};
  args.insert(args.end(), extra.begin(), extra.end());
  return run_dem(args, out.parent_path());
}

TEST(Set, ScalarReachesTheRun) {
  const TempDir tmp;
  const fs::path out = tmp.path() / "out";
  const Result r = run_scene(seed_slope, out, {"--until", "0.1", "--set", "integrator.dt=0.002"});
  ASSERT_EQ(r.code, 0) << r.err;
  const Json summary = read_json(out / "summary.json");
  EXPECT_EQ(summary["settings"]["dt"].number, 0.002);
  EXPECT_EQ(summary["counters"]["accepted_steps"].number, 50);  // 0.1 s / 2 ms
}

TEST(Set, ArrayValueReplacesGravity) {
  const TempDir tmp;
  const fs::path out = tmp.path() / "out";
  // A flat floor: all of g along -z, so the potential energy is m g z with z the start height.
  const Result r = run_scene(seed_slope, out, {"--until", "0.01", "--set", "scene.gravity=[0, 0, -9.8]"});
  ASSERT_EQ(r.code, 0) << r.err;
  const Csv series = read_csv(out / "series.csv");
  ASSERT_FALSE(series.rows.empty());
  EXPECT_NEAR(series.at(0, "potential_energy"), 4.0 * 9.8 * 0.980780618756458, 1e-9);
}

TEST(Set, ValueInsideAnInlineTableReachesTheContact) {
  const TempDir tmp;
  // docs/physics.md 8.2: undamped, e = 1 (Verlet: |e - 1| <= C (omega0 h)^2, here ~1e-5); damped with
  // zeta = 0.1 (the scene's value), e = 0.74408 under force-zero separation.
  const Result damped = run_scene(head_on, tmp.path() / "damped", {});
  const Result undamped = run_scene(head_on, tmp.path() / "undamped", {"--set", "contacts[0].normal_damping.damping_ratio=0"});
  ASSERT_EQ(damped.code, 0) << damped.err;
  ASSERT_EQ(undamped.code, 0) << undamped.err;
  auto restitution = [](const fs::path& out) {
    const Json s = read_json(out / "summary.json");
    return std::sqrt(s["end"]["kinetic_energy"].number / s["start"]["kinetic_energy"].number);
  };
  EXPECT_NEAR(restitution(tmp.path() / "undamped"), 1.0, 1e-4);
  EXPECT_NEAR(restitution(tmp.path() / "damped"), 0.74408, 2e-3);
  // `dem check` reports the damping ratio it will use.
  const Result check = run_dem({"check", head_on, "--set", "contacts[0].normal_damping.damping_ratio=0.5"}, tmp.path());
  EXPECT_EQ(check.code, 0) << check.err;
  EXPECT_NE(check.out.find("zeta = 0.5"), std::string::npos) << check.out;
}

TEST(CliCheck, NamesHowStepDoublingLevelsATouchingGroup) {
  // Under step doubling `dem check` says whether a touching group steps at one level or each particle
  // at its own, and why the exact stepper keeps one level per touching set.
  const TempDir tmp;
  const std::vector<std::string> doubling = {"check", head_on, "--set", "integrator.control=\"doubling\""};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = doubling;
    args.insert(args.end(), extra.begin(), extra.end());
    return run_dem(args, tmp.path());
  };
  const Result island = with({});
  EXPECT_EQ(island.code, 0) << island.err;
  EXPECT_NE(island.out.find("one level per touching group, its finest member's"), std::string::npos) << island.out;
  const Result particle = with({"--set", "integrator.particle_levels=true"});
  EXPECT_EQ(particle.code, 0) << particle.err;
  EXPECT_NE(particle.out.find("a level per particle inside each touching group"), std::string::npos) << particle.out;
  const Result exact = with({"--set", "integrator.method=\"exact\""});
  EXPECT_EQ(exact.code, 0) << exact.err;
  EXPECT_NE(exact.out.find("one level per touching group (the exact stepper's pair flows need both sides live)"),
            std::string::npos)
      << exact.out;
  const Result refused = with({"--set", "integrator.method=\"exact\"", "--set", "integrator.particle_levels=true"});
  EXPECT_EQ(refused.code, 2);
  EXPECT_NE(refused.err.find("the exact stepper keeps one level per touching set"), std::string::npos) << refused.err;
}

TEST(Set, ArrayElementsOfTablesAndOfValues) {
  const TempDir tmp;
  const fs::path out = tmp.path() / "out";
  // particles[0].velocity (a whole array), walls[0].point (moves the slope 0.5 m down: no contact),
  // scene.gravity[0] (one element of an array value).
  const Result r = run_scene(seed_slope, out,
                             {"--until", "0.01", "--set", "particles[0].velocity=[5, 0, 0]", "--set",
                              "walls[0].point=[0, 0, -0.5]", "--set", "scene.gravity[0]=0"});
  ASSERT_EQ(r.code, 0) << r.err;
  const Csv series = read_csv(out / "series.csv");
  const Csv walls = read_csv(out / "walls.csv");
  ASSERT_GE(series.rows.size(), 2u);
  ASSERT_FALSE(walls.rows.empty());
  EXPECT_EQ(series.at(0, "momentum_x"), 4.0 * 5.0);
  EXPECT_EQ(series.at(0, "wall_contacts"), 0);
  for (std::size_t c = 1; c < walls.columns.size(); ++c) EXPECT_EQ(walls.rows[0][c], 0) << walls.columns[c];
  // With gravity along -z only, free flight keeps the x momentum.
  EXPECT_EQ(series.rows.back()[static_cast<std::size_t>(series.column("momentum_x"))], 20.0);

  const Result element = run_scene(seed_slope, tmp.path() / "element", {"--until", "0.01", "--set", "particles[0].velocity[0]=5"});
  ASSERT_EQ(element.code, 0) << element.err;
  EXPECT_EQ(read_csv(tmp.path() / "element" / "series.csv").at(0, "momentum_x"), 20.0);
}

TEST(Set, UnknownPathIsBadInputWithSuggestion) {
  const TempDir tmp;
  Result r = run_dem({"check", seed_slope, "--set", "integrator.dtt=0.1"}, tmp.path());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("did you mean 'dt'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("'integrator.dtt'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("command line"), std::string::npos) << r.err;

  r = run_dem({"run", seed_slope, "--out", (tmp.path() / "out").string(), "--quiet", "--set", "scene.gravty=[0,0,-1]"},
              tmp.path());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("did you mean 'gravity'"), std::string::npos) << r.err;

  r = run_dem({"check", seed_slope, "--set", "walls[3].point=[0,0,0]"}, tmp.path());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("walls[3]"), std::string::npos) << r.err;

  // A bad value from the command line says where it came from.
  r = run_dem({"check", seed_slope, "--set", "integrator.dt=-1"}, tmp.path());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("'integrator.dt'"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("(set on the command line)"), std::string::npos) << r.err;
}

// ---------------------------------------------------------------------------------------------------
// The seed slope through the program (docs/physics.md 8.8, engine variant)

struct SlopeCase {
  const char* name;
  bool disc;
  const char* rolling_mode;
  // Oracle row of docs/physics.md 8.8: rolling at t [s], v [m/s], s [m]; stop t [s], stop s [m].
  double roll_t, roll_v, roll_s, stop_t, stop_s;
};

const SlopeCase slope_cases[] = {
    {"SphereSeedMode", false, "seed", 0.46948, 7.7442, 4.1653, 6.0341, 25.712},
    {"SphereStandardMode", false, "standard", 0.84869, 5.9222, 6.7565, 5.1040, 19.357},
    {"DiscSeedMode", true, "seed", 0.55552, 7.3308, 4.8138, 6.2045, 25.520},
    {"DiscStandardMode", true, "standard", 0.96272, 5.3743, 7.4006, 5.1040, 18.529},
};

struct SlopeMeasured {
  bool rolled = false, stopped = false;
  double roll_t = 0, roll_v = 0, roll_s = 0, stop_t = 0, stop_s = 0;
  double max_speed_after_stop = 0;  // largest |v| after the stop [m/s]
  double max_drift_after_stop = 0;  // largest |s - stop_s| after the stop [m]
  double final_speed = 0;           // |v| of the last row [m/s]
  double v0 = 0;
};

/// Runs the slope and derives the events from series.csv alone.
SlopeMeasured measure_slope(const SlopeCase& c, const fs::path& out) {
  SlopeMeasured m;
  const Result r = run_scene(c.disc ? seed_slope_2d : seed_slope, out,
                             {"--set", std::string("scene.rolling_mode=") + c.rolling_mode, "--set", "integrator.dt=0.001"});
  EXPECT_EQ(r.code, 0) << r.err;
  const Csv series = read_csv(out / "series.csv");
  if (series.rows.size() < 2) return m;
  const double mass = 4, radius = 1, g = 9.8, sin_theta = 0.2 / std::sqrt(1.04);
  const double kappa = c.disc ? 0.5 : 0.4, inertia = kappa * mass * radius * radius;
  const double delta0 = 0.019219, lever = radius - delta0 / 2;
  const std::size_t n = series.rows.size();
  std::vector<double> t(n), v(n), w(n), s(n);
  for (std::size_t i = 0; i < n; ++i) {
    t[i] = series.at(i, "time");
    v[i] = series.at(i, "momentum_x") / mass;
    w[i] = std::sqrt(2 * std::max(series.at(i, "rotational_energy"), 0.0) / inertia);
    s[i] = -(series.at(i, "potential_energy") - series.at(0, "potential_energy")) / (mass * g * sin_theta);
  }
  m.v0 = v[0];
  auto lerp = [](double a, double b, double x) { return a + x * (b - a); };
  for (std::size_t i = 1; i < n && !m.rolled; ++i) {
    const double f0 = v[i - 1] - w[i - 1] * lever, f1 = v[i] - w[i] * lever;
    if (f0 > 0 && f1 <= 0) {
      const double x = f0 / (f0 - f1);
      m.rolled = true;
      m.roll_t = lerp(t[i - 1], t[i], x);
      m.roll_v = lerp(v[i - 1], v[i], x);
      m.roll_s = lerp(s[i - 1], s[i], x);
    }
  }
  const double v_stop = 1e-3 * m.v0;
  for (std::size_t i = 1; i < n && !m.stopped; ++i) {
    if (v[i] < v_stop) {
      const double x = (v[i - 1] - v_stop) / (v[i - 1] - v[i]);
      m.stopped = true;
      m.stop_t = lerp(t[i - 1], t[i], x);
      m.stop_s = lerp(s[i - 1], s[i], x);
    }
  }
  for (std::size_t i = 0; i < n; ++i)
    if (m.stopped && t[i] >= m.stop_t) {
      m.max_speed_after_stop = std::max(m.max_speed_after_stop, std::abs(v[i]));
      m.max_drift_after_stop = std::max(m.max_drift_after_stop, std::abs(s[i] - m.stop_s));
    }
  m.final_speed = std::abs(v[n - 1]);
  return m;
}

void PrintTo(const SlopeCase& c, std::ostream* os) { *os << c.name; }

class SeedSlopeTest : public ::testing::TestWithParam<SlopeCase> {};

TEST_P(SeedSlopeTest, MatchesTheOracleTableWithinHalfAPercent) {
  const SlopeCase& c = GetParam();
  const TempDir tmp;
  const SlopeMeasured m = measure_slope(c, tmp.path() / "out");
  ASSERT_EQ(m.v0, 10.0);
  ASSERT_TRUE(m.rolled) << "never reached rolling (v = omega a)";
  ASSERT_TRUE(m.stopped) << "never stopped (v < 1e-3 v0)";
  std::printf("  measured: rolling at t = %.5f s, v = %.5f m/s, s = %.5f m; stop t = %.5f s, s = %.5f m\n", m.roll_t,
              m.roll_v, m.roll_s, m.stop_t, m.stop_s);
  auto within = [](double measured, double oracle) { return std::abs(measured - oracle) <= 0.005 * std::abs(oracle); };
  EXPECT_PRED2(within, m.roll_t, c.roll_t) << "time to rolling [s]";
  EXPECT_PRED2(within, m.roll_v, c.roll_v) << "speed at rolling [m/s]";
  EXPECT_PRED2(within, m.roll_s, c.roll_s) << "distance at rolling [m]";
  EXPECT_PRED2(within, m.stop_t, c.stop_t) << "stop time [s]";
  EXPECT_PRED2(within, m.stop_s, c.stop_s) << "stop distance [m]";
}

TEST_P(SeedSlopeTest, StaysAtRestAfterStopping) {
  // docs/physics.md 8.8: at rest for good once stopped (tan(theta) = 0.2 < mu_rs = 0.3).
  const SlopeCase& c = GetParam();
  const TempDir tmp;
  const SlopeMeasured m = measure_slope(c, tmp.path() / "out");
  ASSERT_TRUE(m.stopped);
  // The contact springs ring while the kinetic rolling torque hands over to the static hold (the
  // rigid oracle switches instantly): the ball rocks by a few centimetres, then rests. It must never
  // roll away (before the fix it ran back up the slope at 4 m/s) and must be at rest at the end.
  EXPECT_LT(m.max_speed_after_stop, 1e-2 * m.v0) << "the ball moves again after stopping at t = " << m.stop_t << " s";
  EXPECT_LT(m.max_drift_after_stop, 2e-3 * m.stop_s) << "the ball wanders after stopping";
  EXPECT_LT(m.final_speed, 1e-4 * m.v0) << "the ball is not at rest at the end of the run";
}

INSTANTIATE_TEST_SUITE_P(EngineVariant, SeedSlopeTest, ::testing::ValuesIn(slope_cases),
                         [](const ::testing::TestParamInfo<SlopeCase>& p) { return std::string(p.param.name); });

// ---------------------------------------------------------------------------------------------------
// Output files

const std::vector<std::string> expected_series_columns = {
    "time",           "kinetic_energy", "rotational_energy", "potential_energy", "elastic_energy",
    "dissipated_energy", "momentum_x",  "momentum_y",        "momentum_z",       "contacts",
    "wall_contacts",  "sync_intervals", "accepted_steps",    "rejected_steps",   "forced_steps",
    "particle_steps", "force_evaluations", "pair_rebuilds",
    "round_redos", "finest_level", "coarsest_level"};  // engine/output.cpp series_columns()

TEST(Outputs, FilesHaveTheDocumentedShape) {
  const TempDir tmp;
  const fs::path out = tmp.path() / "out";
  // head_on: 2 particles, dt = 1e-5 s, rows every 1e-4 s, snapshots every 1e-3 s, until 0.02 s.
  const double dt = 1e-5, interval = 1e-4, until = 0.02;
  const Result r = run_scene(head_on, out, {});
  ASSERT_EQ(r.code, 0) << r.err;

  const Csv series = read_csv(out / "series.csv");
  EXPECT_EQ(series.columns, expected_series_columns);
  ASSERT_FALSE(series.rows.empty());
  for (const auto& row : series.rows) ASSERT_EQ(row.size(), series.columns.size());
  EXPECT_EQ(series.rows.front()[0], 0.0);
  EXPECT_GE(series.rows.back()[0], until);
  EXPECT_LT(series.rows.back()[0], until + dt * 1.000001);
  EXPECT_EQ(series.rows.size(), static_cast<std::size_t>(std::llround(until / interval)) + 1);
  for (std::size_t k = 1; k < series.rows.size(); ++k) {
    EXPECT_GT(series.rows[k][0], series.rows[k - 1][0]) << "row " << k;
    // The first sync time (here every dt) at or after k * interval.
    EXPECT_NEAR(series.rows[k][0], k * interval, 1e-3 * dt) << "row " << k;
  }

  const Csv walls = read_csv(out / "walls.csv");
  EXPECT_EQ(walls.columns, std::vector<std::string>{"time"});  // head_on has no walls
  EXPECT_EQ(walls.rows.size(), series.rows.size());

  const Json summary = read_json(out / "summary.json");
  ASSERT_EQ(summary.kind, Json::Kind::object);
  for (const char* key : {"status", "time", "settings", "counters", "wall_time", "run_particle_steps",
                          "particle_steps_per_second", "start", "end", "state_hash", "provenance"})
    EXPECT_TRUE(summary.has(key)) << "summary.json lacks '" << key << "'";
  EXPECT_EQ(summary["status"].string, "ok");
  EXPECT_EQ(summary["time"].number, series.rows.back()[0]);
  EXPECT_EQ(summary["settings"].kind, Json::Kind::object);
  for (const char* key : {"accepted_steps", "rejected_steps", "forced_steps", "particle_steps", "force_evaluations"})
    EXPECT_EQ(summary["counters"][key].kind, Json::Kind::number) << "counters." << key;
  EXPECT_EQ(summary["counters"]["particle_steps"].number, series.rows.back()[static_cast<std::size_t>(series.column("particle_steps"))]);
  EXPECT_GT(summary["wall_time"].number, 0);
  EXPECT_GT(summary["particle_steps_per_second"].number, 0);
  EXPECT_EQ(summary["run_particle_steps"].number, summary["counters"]["particle_steps"].number) << "not resumed";
  EXPECT_EQ(summary["start"]["kinetic_energy"].number, series.at(0, "kinetic_energy"));
  EXPECT_TRUE(std::regex_match(summary["state_hash"].string, std::regex("[0-9a-f]{16}"))) << summary["state_hash"].string;
  const Json& provenance = summary["provenance"];
  for (const char* key : {"version", "git_hash", "compiler", "flags", "threads", "seeds"})
    EXPECT_TRUE(provenance.has(key)) << "provenance lacks '" << key << "'";
  EXPECT_FALSE(provenance["version"].string.empty());
  EXPECT_GE(provenance["threads"].number, 1);
  EXPECT_EQ(provenance["seeds"].kind, Json::Kind::array);

  const std::string pvd = read_text(out / "particles.pvd");
  const auto files = xml_attributes(pvd, "DataSet", "file");
  const auto times = xml_attributes(pvd, "DataSet", "timestep");
  EXPECT_EQ(files.size(), 21u);  // snapshots at 0, 1 ms, ..., 20 ms
  ASSERT_EQ(times.size(), files.size());
  for (std::size_t k = 0; k < files.size(); ++k) {
    ASSERT_TRUE(fs::exists(out / files[k])) << files[k];
    const auto points = xml_attributes(read_text(out / files[k]), "Piece", "NumberOfPoints");
    ASSERT_EQ(points.size(), 1u) << files[k];
    EXPECT_EQ(points[0], "2") << files[k];
    if (k > 0) {
      EXPECT_GT(std::stod(times[k]), std::stod(times[k - 1]));
    }
  }
}

TEST(Outputs, RowsAndSnapshotsAtTheFirstSyncTimeAtOrAfterEachMultiple) {
  // docs/design.md, Outputs: a row at the first sync time at or after each multiple of output.interval.
  // The seed slope: sync times every 1 ms, rows every 5 ms, snapshots every 0.1 s: all multiples of 1 ms
  // are sync times, so every row and snapshot falls on its multiple.
  const TempDir tmp;
  const fs::path out = tmp.path() / "out";
  const Result r = run_scene(seed_slope, out, {"--until", "1"});
  ASSERT_EQ(r.code, 0) << r.err;
  const Csv series = read_csv(out / "series.csv");
  ASSERT_EQ(series.rows.size(), 201u);
  for (std::size_t k = 0; k < series.rows.size(); ++k) EXPECT_NEAR(series.rows[k][0], k * 0.005, 1e-9) << "row " << k;
  const Csv walls = read_csv(out / "walls.csv");
  EXPECT_EQ(walls.columns, (std::vector<std::string>{"time", "slope_fx", "slope_fy", "slope_fz", "slope_tx", "slope_ty",
                                                      "slope_tz"}));
  EXPECT_EQ(walls.rows.size(), series.rows.size());
  const auto times = xml_attributes(read_text(out / "particles.pvd"), "DataSet", "timestep");
  ASSERT_EQ(times.size(), 11u);
  for (std::size_t k = 0; k < times.size(); ++k) EXPECT_NEAR(std::stod(times[k]), k * 0.1, 1e-9) << "snapshot " << k;
}

// ---------------------------------------------------------------------------------------------------
// Divergence and determinism

TEST(ExitCodes, DivergenceExitsThreeWithStatusDiverged) {
  const TempDir tmp;
  // One undamped ball rattling in a box. omega0 = sqrt(k/m) = 316 /s, so dt = 0.05 s is 16x past the
  // stability limit 2/omega0: each wall hit multiplies the speed until the state is no longer finite.
  const fs::path scene = tmp.path() / "rattle.toml";
  std::ofstream(scene) << "[[contacts]]\nnormal_stiffness = 1e5\n"
                          "[[walls]]\ntype = \"box\"\nhalf_extents = [0.2, 0.2, 0.2]\n"
                          "[[particles]]\nposition = [0.0, 0.0, 0.0]\nvelocity = [1.0, 0.3, 0.0]\nradius = 0.1\nmass = 1.0\n"
                          "[integrator]\ndt = 1e-4\n[run]\nuntil = 20.0\n[output]\ninterval = 0.5\nsnapshot_interval = 0\n";
  const fs::path stable = tmp.path() / "stable", diverged = tmp.path() / "diverged";
  Result r = run_scene(scene.string(), stable, {"--until", "0.05"});
  ASSERT_EQ(r.code, 0) << r.err;  // the scene itself is fine
  r = run_scene(scene.string(), diverged, {"--set", "integrator.dt=0.05"});
  EXPECT_EQ(r.code, 3) << r.err;
  const Json summary = read_json(diverged / "summary.json");
  EXPECT_EQ(summary["status"].string, "diverged");
  EXPECT_LT(summary["time"].number, 20.0);
}

TEST(Determinism, StateHashDoesNotDependOnThreads) {
  const TempDir tmp;
  // The settled 20,000-sphere bed, 69 steps: ~36,000 contacts.
  const std::string bed = (source_dir / "scenes" / "dense_bed.toml").string();
  std::vector<Json> summaries;
  for (const char* threads : {"1", "2"}) {
    const fs::path out = tmp.path() / (std::string("threads_") + threads);
    const Result r = run_scene(bed, out, {"--threads", threads, "--until", "5e-4", "--set", "output.snapshot_interval=0"});
    ASSERT_EQ(r.code, 0) << r.err;
    summaries.push_back(read_json(out / "summary.json"));
    EXPECT_EQ(summaries.back()["provenance"]["threads"].number, std::stod(threads));
  }
  const Csv series = read_csv(tmp.path() / "threads_1" / "series.csv");
  ASSERT_FALSE(series.rows.empty());
  EXPECT_GT(series.at(series.rows.size() - 1, "contacts"), 1000) << "the test needs many contacts";
  EXPECT_EQ(summaries[0]["state_hash"].string, summaries[1]["state_hash"].string);
  EXPECT_FALSE(summaries[0]["state_hash"].string.empty());
}

}  // namespace

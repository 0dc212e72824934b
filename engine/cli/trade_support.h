#pragma once
// What the parts of `dem trade` share (trade_command.cpp describes the command): the metrics, the
// samples of a run, the plan of the comparison; the runs (trade_runs.cpp), the comparison
// (trade_metrics.cpp) and the reference file (trade_files.cpp).
#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <iterator>
#include <limits>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "engine/scene.h"
#include "engine/world.h"

namespace dem::cli::trade {

inline constexpr double inf = std::numeric_limits<double>::infinity();
inline constexpr double nan = std::numeric_limits<double>::quiet_NaN();

// ---------------------------------------------------------------------------------------------------
// Metrics (trade_metrics.cpp)

/// Observables of a many-body scene, measured at every sample time and compared at the end time.
enum Observable { dissipated_energy, bed_height, kinetic_energy, wall_force, power_draw, fines_dissipation_share, observable_count };
inline constexpr const char* observable_names[observable_count] = {"dissipated_energy", "bed_height", "kinetic_energy",
                                                        "wall_force", "power_draw", "fines_dissipation_share"};
inline constexpr const char* observable_units[observable_count] = {"J", "m", "J", "N", "W", "1"};
inline constexpr const char* observable_meanings[observable_count] = {
    "energy dissipated by contacts since the start (the checkpoint's time with --from); at the end time",
    "mean height (along -gravity; z without gravity; y in 2D) of the highest 10% of particles; at the end time",
    "translational plus rotational kinetic energy; at the end time",
    "sum over walls of the magnitude of the force of the particles on the wall; at the end time",
    "mean power of the moving walls on the particles since the start (a mill's drive power): wall work / time; at the "
    "end time",
    ("share of the energy dissipated by the contact events ended since the start that falls to the smallest size "
     "class (mill.size_classes; a contact between two classes counts half to each), 0 to 1; at the end time")};

/// The collision energy spectrum (a mill's): compared as a whole at the end time.
inline constexpr const char* spectrum_name = "collision_spectrum";
inline constexpr const char* spectrum_meaning =
    "distance of the collision energy spectra: over every kind of event (ball-ball and ball-liner, or each pair of size "
    "classes and each class with the liner), impact energy and normal and "
    "tangential loss, and every bin, the sum of |E_run - E_ref| over the sum of E_run + E_ref (E: energy booked in "
    "the bin by the events ended since the start); 0 for the same spectrum, 1 for disjoint ones; at the end time";

/// The metric columns: the four trajectory columns, the observables and the spectrum, in this order
/// when chosen.
struct Metrics {
  bool trajectory = false;
  bool observable[observable_count] = {false, false, false, false, false, false};
  bool spectrum = false;

  std::vector<std::string> columns() const {
    std::vector<std::string> c;
    if (trajectory)
      for (const char* name : {"position_max", "position_rms", "velocity_max", "velocity_rms"}) c.push_back(name);
    for (int o = 0; o < observable_count; ++o)
      if (observable[o]) c.push_back(observable_names[o]);
    if (spectrum) c.push_back(spectrum_name);
    return c;
  }
  bool any_observable() const {
    return spectrum || std::any_of(std::begin(observable), std::end(observable), [](bool b) { return b; });
  }
};

/// The metrics of [accuracy], else chosen by the scene's size, walls and spectra.
Metrics choose_metrics(const Scene& scene);
/// The unit of a metric column's error (trade_metrics.txt).
std::string unit_of(const std::string& column);

// ---------------------------------------------------------------------------------------------------
// Runs (trade_runs.cpp)

/// The state of a run at one sample time; positions and velocities in id order (trajectory metric only).
struct Sample {
  double time = 0;
  std::vector<Vec3> position, velocity;
  double observable[observable_count] = {nan, nan, nan, nan, nan, nan};
  std::vector<double> spectrum;  // energy per (kind, quantity, bin) [J]; empty: none booked or not read
};

struct RunResult {
  std::string status = "ok";  // ok, diverged, failed
  std::string why;            // for diverged and failed
  double wall_time = 0;       // [s]
  RunCounters counters;
  std::vector<Sample> samples;  // k = 0..K
};

struct Plan {
  double interval = 0;     // T: the comparison interval [s]
  std::int64_t count = 0;  // K: samples after the start
  Metrics metrics;
  Vec3 up = Vec3::UnitZ();
  // With --from: the checkpoint every run starts from, the scene's hashes it must match, and its
  // time, from which the samples are taken (start + k T) and the metrics counted.
  std::string checkpoint;
  SceneHashes hashes;
  double start = 0;  // [s]
};

/// The direction "up" for the bed height: against gravity; z without gravity, y in 2D.
Vec3 up_direction(const WorldConfig& config);
/// Runs `config` (from the plan's checkpoint when it has one) to K T after its start, sampling at every
/// k T. A seed above 0 perturbs the start: velocities by 1e-9 relative, and positions by 1e-12 m unless
/// the run starts from a checkpoint (per component, seeded). Never throws for a failing run: the
/// status says it.
RunResult run_setting(WorldConfig config, const Plan& plan, std::uint64_t seed = 0);

// ---------------------------------------------------------------------------------------------------
// Comparison (trade_metrics.cpp)

/// Errors of `run` against `reference`, one per metric column; infinite for a run that did not finish.
std::vector<double> errors_of(const std::vector<Sample>& run, bool finished, const std::vector<Sample>& reference,
                              const Metrics& metrics);
/// Size of each metric in the reference (for a round-off floor): largest |x|, |v|, |observable|.
std::vector<double> scales_of(const std::vector<Sample>& reference, const Metrics& metrics);

// ---------------------------------------------------------------------------------------------------
// Files (trade_files.cpp)

/// A number for a CSV cell (nan and inf spelt out).
std::string number(double v);
/// reference.csv of the named runs (trade_files.cpp describes its columns).
void write_reference(const std::filesystem::path& path, const std::vector<std::pair<std::string, const RunResult*>>& runs);
/// The runs of a reference file at the plan's sample times (reference.csv or a `dem run` trajectories.csv).
std::map<std::string, std::vector<Sample>> read_reference(const std::string& file, const Plan& plan, std::size_t particles);
/// The items joined by `sep`.
std::string join(const std::vector<std::string>& items, const std::string& sep);

}  // namespace dem::cli::trade

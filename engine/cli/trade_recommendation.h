#pragma once
// The recommendation that ends `dem trade`: per metric, the cheapest setting whose error is within a
// threshold (the user's --target, else the noise floor). Pure functions of the measured rows, so they
// are tested without running simulations; trade_command.cpp prints and writes what they choose.
//
// Cost is particle-steps (rejected trials included): unlike wall time, it does not depend on the
// machine, its load or the thread count, so the same trade recommends the same setting everywhere.
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace dem::cli::trade {

/// A measured setting as the recommendation weighs it (one row of trade.csv).
struct CostedRow {
  std::string control;               // fixed or doubling
  double dt = 0;                     // the fixed step, or the doubling runs' dt_base [s]
  double tolerance = 0;              // doubling only
  std::uint64_t particle_steps = 0;  // the cost compared
  double wall_time = 0;              // [s], printed beside
  bool finished = false;             // status ok: diverged and failed rows never qualify
  std::vector<double> errors;        // one per metric column
};

/// What a metric's rows are held against: the user's target, else the noise floor, else nothing.
enum class Criterion { target, noise, none };

const char* criterion_name(Criterion criterion);

/// The outcome for one metric; the indices are into the rows given.
struct Choice {
  Criterion criterion = Criterion::none;
  double threshold = 0;                       // the target or the floor; unused for none
  std::optional<std::size_t> chosen;          // the cheapest row within the threshold
  std::optional<std::size_t> cheapest_fixed;  // the cheapest fixed row within it
  std::optional<std::size_t> cheapest_doubling;
  std::optional<std::size_t> most_accurate;   // the finished row of smallest error (named when none qualifies)
};

/// For metric column `metric`: a row qualifies when it finished and its error is at or below the
/// threshold (`target` when given, else `noise_floor` when it is finite, else none qualifies and
/// the criterion is none). Cheapest: fewest particle-steps, then the smaller error, then the earlier row.
Choice recommend(const std::vector<CostedRow>& rows, std::size_t metric, double noise_floor,
                 std::optional<double> target);

/// The --target items ("METRIC=VALUE", VALUE an absolute error >= 0 in the metric's unit) by metric
/// column. Throws InputError naming --target, the bad item and the valid choices (the `columns`).
std::map<std::string, double> parse_targets(const std::vector<std::string>& items,
                                            const std::vector<std::string>& columns);

}  // namespace dem::cli::trade

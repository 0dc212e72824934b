// `dem trade`: the choice of the recommended setting per metric, and the --target items
// (trade_recommendation.h).
#include "engine/cli/trade_recommendation.h"

#include <algorithm>
#include <cmath>

#include "engine/input_error.h"
#include "engine/number_text.h"

namespace dem::cli::trade {
namespace {

/// Whether row `a` is cheaper than row `b` for `metric`: fewer particle-steps, then the smaller error
/// (the earlier row wins a full tie, as the caller keeps the first it found).
bool cheaper(const CostedRow& a, const CostedRow& b, std::size_t metric) {
  if (a.particle_steps != b.particle_steps) return a.particle_steps < b.particle_steps;
  return a.errors[metric] < b.errors[metric];
}

/// Whether row `a` is more accurate than row `b`: the smaller error, then fewer particle-steps.
bool more_accurate(const CostedRow& a, const CostedRow& b, std::size_t metric) {
  if (a.errors[metric] != b.errors[metric]) return a.errors[metric] < b.errors[metric];
  return a.particle_steps < b.particle_steps;
}

/// Keeps in `best` the better of itself and row `k`.
template <typename Better>
void keep_better(std::optional<std::size_t>& best, std::size_t k, const std::vector<CostedRow>& rows, Better better) {
  if (!best || better(rows[k], rows[*best])) best = k;
}

std::string trimmed(const std::string& s) {
  const auto first = s.find_first_not_of(" \t");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t") - first + 1);
}

}  // namespace

const char* criterion_name(Criterion criterion) {
  switch (criterion) {
    case Criterion::target: return "target";
    case Criterion::noise: return "noise";
    case Criterion::none: break;
  }
  return "none";
}

Choice recommend(const std::vector<CostedRow>& rows, std::size_t metric, double noise_floor,
                 std::optional<double> target) {
  Choice c;
  if (target) {
    c.criterion = Criterion::target;
    c.threshold = *target;
  } else if (std::isfinite(noise_floor)) {
    c.criterion = Criterion::noise;
    c.threshold = noise_floor;
  }
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const CostedRow& row = rows[k];
    if (!row.finished || !std::isfinite(row.errors[metric])) continue;
    const auto by_cost = [metric](const CostedRow& a, const CostedRow& b) { return cheaper(a, b, metric); };
    const auto by_error = [metric](const CostedRow& a, const CostedRow& b) { return more_accurate(a, b, metric); };
    keep_better(c.most_accurate, k, rows, by_error);
    if (c.criterion == Criterion::none || !(row.errors[metric] <= c.threshold)) continue;
    keep_better(c.chosen, k, rows, by_cost);
    keep_better(row.control == "fixed" ? c.cheapest_fixed : c.cheapest_doubling, k, rows, by_cost);
  }
  return c;
}

std::map<std::string, double> parse_targets(const std::vector<std::string>& items,
                                            const std::vector<std::string>& columns) {
  std::string choices;
  for (const std::string& c : columns) choices += (choices.empty() ? "" : ", ") + c;
  const std::string example = columns.empty() ? "METRIC=1e-6" : columns.front() + "=1e-6";
  auto bad = [&](const std::string& item, const std::string& why) {
    throw InputError("--target", 0, 0, "",
                     "'" + item + "': " + why + "; expected METRIC=VALUE[,METRIC=VALUE...], e.g. " + example +
                         ", with VALUE an absolute error >= 0 in the metric's unit (trade_metrics.txt) and METRIC "
                         "one of this scene's metrics: " + choices);
  };
  std::map<std::string, double> targets;
  for (const std::string& raw : items) {
    const std::string item = trimmed(raw);
    const auto equals = item.find('=');
    if (equals == std::string::npos) bad(item, "no '='");
    const std::string metric = trimmed(item.substr(0, equals)), value_text = trimmed(item.substr(equals + 1));
    if (std::find(columns.begin(), columns.end(), metric) == columns.end())
      bad(item, "unknown metric '" + metric + "'");
    double value = 0;
    if (!text::parse_double(value_text, value) || !std::isfinite(value))
      bad(item, "'" + value_text + "' is not a finite number");
    if (value < 0) bad(item, "'" + value_text + "' is negative");
    if (!targets.emplace(metric, value).second) bad(item, "a second target for " + metric);
  }
  return targets;
}

}  // namespace dem::cli::trade

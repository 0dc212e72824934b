// `dem trade`: the metrics and the comparison of runs with the reference (trade_support.h).
#include <cmath>

#include "engine/cli/trade_support.h"

namespace dem::cli::trade {
namespace {

/// Distance of two spectra in [0, 1] (spectrum_meaning); NaN when either has none.
double spectrum_distance(const std::vector<double>& run, const std::vector<double>& reference) {
  if (run.empty() || run.size() != reference.size()) return nan;
  double difference = 0, size = 0;
  for (std::size_t b = 0; b < run.size(); ++b) {
    difference += std::abs(run[b] - reference[b]);
    size += std::abs(run[b]) + std::abs(reference[b]);
  }
  return size > 0 ? difference / size : 0;
}

}  // namespace

Metrics choose_metrics(const Scene& scene) {
  Metrics m;
  if (!scene.accuracy.metrics.empty()) {
    for (const std::string& name : scene.accuracy.metrics) {
      if (name == "trajectory") m.trajectory = true;
      for (int o = 0; o < observable_count; ++o)
        if (name == observable_names[o]) m.observable[o] = true;
      if (name == spectrum_name) m.spectrum = true;
    }
    return m;
  }
  if (scene.world.particles.size() <= 100) {
    m.trajectory = true;
  } else {
    m.observable[dissipated_energy] = m.observable[bed_height] = m.observable[kinetic_energy] = true;
    m.observable[wall_force] = !scene.world.walls.empty();
  }
  // Moving walls do work: for a mill, its power draw is the observable users ask for.
  m.observable[power_draw] = std::any_of(scene.world.walls.begin(), scene.world.walls.end(), [](const WallConfig& w) {
    return w.velocity.norm() > 0 || w.angular_velocity.norm() > 0;
  });
  // A scene that books collision spectra (a mill) is measured by them too; only Verlet books them.
  m.spectrum = scene.world.collision_spectra && scene.world.integrator.method == Method::verlet;
  // With size classes, the share of the dissipation that falls to the smallest (the fines).
  m.observable[fines_dissipation_share] = m.spectrum && !scene.world.spectra_size_classes.empty();
  return m;
}

std::string unit_of(const std::string& column) {
  if (column.rfind("position", 0) == 0) return "m";
  if (column.rfind("velocity", 0) == 0) return "m/s";
  for (int o = 0; o < observable_count; ++o)
    if (column == observable_names[o]) return observable_units[o];
  return column == spectrum_name ? "1" : "";
}

/// Errors of `run` against `reference`, one per metric column; infinite for a run that did not finish.
std::vector<double> errors_of(const std::vector<Sample>& run, bool finished, const std::vector<Sample>& reference,
                              const Metrics& metrics) {
  std::vector<double> e;
  const std::size_t columns = metrics.columns().size();
  if (!finished || run.size() != reference.size()) return std::vector<double>(columns, inf);
  if (metrics.trajectory) {
    double x_max = 0, v_max = 0, x_sum = 0, v_sum = 0;
    std::size_t n = 0;
    for (std::size_t k = 1; k < run.size(); ++k)
      for (std::size_t p = 0; p < reference[k].position.size(); ++p) {
        const double dx = (run[k].position[p] - reference[k].position[p]).norm();
        const double dv = (run[k].velocity[p] - reference[k].velocity[p]).norm();
        x_max = std::max(x_max, dx), v_max = std::max(v_max, dv);
        x_sum += dx * dx, v_sum += dv * dv;
        ++n;
      }
    const double count = static_cast<double>(std::max<std::size_t>(n, 1));
    e.insert(e.end(), {x_max, std::sqrt(x_sum / count), v_max, std::sqrt(v_sum / count)});
  }
  for (int o = 0; o < observable_count; ++o)
    if (metrics.observable[o]) e.push_back(std::abs(run.back().observable[o] - reference.back().observable[o]));
  for (double& v : e)
    if (!std::isfinite(v)) v = inf;
  if (metrics.spectrum) {
    const double d = spectrum_distance(run.back().spectrum, reference.back().spectrum);
    e.push_back(std::isfinite(d) ? d : inf);
  }
  return e;
}

/// Size of each metric in the reference (for a round-off floor): largest |x|, |v|, |observable|.
std::vector<double> scales_of(const std::vector<Sample>& reference, const Metrics& metrics) {
  std::vector<double> s;
  if (metrics.trajectory) {
    double x = 0, v = 0;
    for (const Sample& sample : reference)
      for (std::size_t p = 0; p < sample.position.size(); ++p)
        x = std::max(x, sample.position[p].norm()), v = std::max(v, sample.velocity[p].norm());
    s = {x, x, v, v};  // s is empty here (assign: GCC 12 misreads insert as an overflow)
  }
  for (int o = 0; o < observable_count; ++o)
    if (metrics.observable[o]) {
      double m = 0;
      for (const Sample& sample : reference) m = std::max(m, std::abs(sample.observable[o]));
      s.push_back(m);
    }
  if (metrics.spectrum) s.push_back(1);  // a relative distance
  return s;
}

}  // namespace dem::cli::trade

// `dem trade`: the speed-accuracy trade of a scene (docs/design.md, Measuring the trade). Runs the scene in
// process through the World API at each fixed step (--fixed) and each step-doubling tolerance (--tol),
// compares each run with a reference run at common sync times and writes, into the output folder:
//   trade.csv            one row per setting: control, method, dt, tolerance, cost, status, <metric>_error,
//                        and <metric>_noise when perturbed reference runs gave a noise floor
//   trade_metrics.txt    one row per metric column: unit, reference error estimate, noise, meaning (CSV)
//   trade_reference.txt  how the reference was made (CSV of key,value)
//   recommendation.csv   one row per metric: the cheapest setting within the --target or the noise
//                        floor (trade_recommendation.h), and the cheapest fixed and doubling ones
//   reference.csv        the reference's samples, loadable by a later `dem trade --reference FILE`
//   trade.png            by bench/plot_trade.py when Python and matplotlib are there
//
// Common sync times. Every run is sampled at t_k = t_0 + k T, k = 1..K, from its start t_0 (0, or
// with --from the time of the checkpoint every run, references included, starts from; the metrics
// then count from there). T, the comparison interval, is output.interval raised to a whole multiple
// of the largest fixed step; every fixed step must divide T.
// Doubling runs use dt_base = T and level_max = 0 (so their sync interval is T), with level_min keeping
// the scene's finest step (dt_base * 2^level_min). The reference is a fixed step of 1/8 of the smallest
// fixed step (the scene's dt without --fixed), so its sync times include every t_k; it is checked by a
// run at half its step, and the difference of the two is the reference's own error estimate.
//
// Metrics (chosen by the scene's [accuracy] section, else by its size): few-body scenes (<= 100
// particles) compare trajectories (max and RMS deviation of positions and velocities over particles
// and sample times); many-body scenes, whose trajectories are chaotic, compare observables at the end
// time: dissipated energy, bed height, kinetic energy and the wall force (and a mill's power draw and
// collision energy spectrum; the spectrum is not stored in reference.csv, so it is measured only
// against a reference made in the same run). There, three reference runs
// with perturbed initial states (velocities by 1e-9 relative, positions by 1e-12 m, counter-based
// deterministic draws) give the noise floor: differences below it mean nothing.
//
// A setting whose run goes non-finite or fails the energy audit of `dem run` (energy appearing beyond
// the work put in, or overlaps beyond half a radius) is a row with status `diverged` and infinite
// errors (a setting the World refuses to build is `failed`, likewise); the command still exits 0. A
// failing reference exits 1; bad options or scenes exit 2.
// The driver; the metrics, runs and reference files are in trade_support.h and trade_*.cpp.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "engine/cli/commands.h"
#include "engine/cli/plot_script.h"
#include "engine/cli/trade_recommendation.h"
#include "engine/cli/trade_support.h"
#include "engine/input_error.h"
#include "engine/atomic_file.h"
#include "engine/world.h"

namespace dem::cli {
namespace {

using namespace trade;
namespace fs = std::filesystem;

/// printf to stdout unless quiet, flushed (progress of long runs).
template <typename... Args>
void say(bool quiet, const char* format, Args... args) {
  if (!quiet) {
    std::printf(format, args...);
    std::fflush(stdout);
  }
}

void check_options(const TradeOptions& options) {
  for (double dt : options.fixed)
    if (!(dt > 0) || !std::isfinite(dt)) throw InputError("--fixed", 0, 0, "", "steps must be finite and > 0, got " + number(dt));
  for (double tol : options.tolerances)
    if (!(tol > 0) || !std::isfinite(tol)) throw InputError("--tol", 0, 0, "", "tolerances must be finite and > 0, got " + number(tol));
  if (options.fixed.empty() && options.tolerances.empty())
    throw InputError("dem trade", 0, 0, "", "nothing to measure: give --fixed DT,DT,... and/or --tol TOL,TOL,...");
  if (!options.method.empty() && options.method != "verlet" && options.method != "exact")
    throw InputError("--method", 0, 0, "", "'" + options.method + "' is not valid; expected verlet or exact");
}

bool reference_from_file(const TradeOptions& options) { return !options.reference.empty() && options.reference != "auto"; }

/// The scene with the command line's settings; rejects a spectrum metric the runs cannot measure.
Scene trade_scene(const TradeOptions& options) {
  std::vector<std::string> overrides = options.overrides;
  if (!options.method.empty()) overrides.push_back("integrator.method=" + options.method);
  Scene scene = load_scene(options.scene, overrides);
  if (options.threads >= 0) scene.world.threads = options.threads;
  if (options.until > 0) scene.run.until = options.until;
  const bool spectrum_asked = std::find(scene.accuracy.metrics.begin(), scene.accuracy.metrics.end(),
                                        spectrum_name) != scene.accuracy.metrics.end();
  if (spectrum_asked && !(scene.world.collision_spectra && scene.world.integrator.method == Method::verlet))
    throw InputError(scene.file, 0, 0, "accuracy.metrics",
                     "collision_spectrum needs a scene that books collision spectra: a [mill] run with "
                     "integrator.method = \"verlet\"");
  if (spectrum_asked && reference_from_file(options))
    throw InputError("--reference", 0, 0, "", "collision_spectrum is not stored in a reference file: use --reference auto "
                                             "or leave collision_spectrum out of accuracy.metrics");
  const bool share_asked = std::find(scene.accuracy.metrics.begin(), scene.accuracy.metrics.end(),
                                     observable_names[fines_dissipation_share]) != scene.accuracy.metrics.end();
  if (share_asked && !(scene.world.collision_spectra && scene.world.integrator.method == Method::verlet &&
                       !scene.world.spectra_size_classes.empty()))
    throw InputError(scene.file, 0, 0, "accuracy.metrics",
                     "fines_dissipation_share needs a scene that books collision spectra in size classes: a [mill] "
                     "with size_classes and integrator.method = \"verlet\"");
  return scene;
}

/// The smallest fixed step (the scene's dt without --fixed): the reference's is an eighth of it.
double base_step(const Scene& scene, const TradeOptions& options) {
  return options.fixed.empty() ? scene.world.integrator.dt : *std::min_element(options.fixed.begin(), options.fixed.end());
}

/// The comparison: output.interval raised to a multiple of the largest fixed step, which every
/// fixed step must divide; the start (the scene's, or the --from checkpoint's time), the sample
/// count and the metrics.
Plan make_plan(const Scene& scene, const TradeOptions& options) {
  const double base_dt = base_step(scene, options);
  const double largest = options.fixed.empty() ? base_dt : *std::max_element(options.fixed.begin(), options.fixed.end());
  Plan plan;
  if (!options.from.empty()) {
    CheckpointHeader header;
    try {
      header = read_checkpoint_header(options.from);
    } catch (const std::runtime_error& e) {
      throw InputError(options.from, 0, 0, "--from", e.what());
    }
    if (const std::string why = start_refusal(header, scene.hashes(), scene.world.integrator.method); !why.empty())
      throw InputError(options.from, 0, 0, "--from", "the checkpoint: " + why);
    if (!(scene.run.until > header.time)) {
      char text[200];
      std::snprintf(text, sizeof text, "the end time %.9g s is not after the checkpoint's time %.9g s: give a later --until",
                    scene.run.until, header.time);
      throw InputError(options.from, 0, 0, "--from", text);
    }
    plan.checkpoint = options.from;
    plan.hashes = scene.hashes();
    plan.start = header.time;
  }
  plan.interval = std::ceil(scene.output.interval / largest - 1e-9) * largest;
  for (double dt : options.fixed.empty() ? std::vector<double>{base_dt} : options.fixed) {
    const double r = plan.interval / dt;
    if (std::abs(r - std::round(r)) > 1e-6 * r) {
      char text[300];
      std::snprintf(text, sizeof text,
                    "dt = %.6g s does not divide the comparison interval %.6g s (output.interval raised to a multiple "
                    "of the largest step): every step must divide the largest one, e.g. 1e-3,5e-4,2.5e-4",
                    dt, plan.interval);
      throw InputError("--fixed", 0, 0, "", text);
    }
  }
  plan.count = std::max<std::int64_t>(
      1, static_cast<std::int64_t>(std::ceil((scene.run.until - plan.start) / plan.interval - 1e-9)));
  plan.metrics = choose_metrics(scene);
  if (reference_from_file(options)) plan.metrics.spectrum = false;  // a default only here: the file holds no spectrum
  plan.up = up_direction(scene.world);
  return plan;
}

/// The scene's world at a fixed step (level 0).
WorldConfig fixed_config_of(const Scene& scene) {
  WorldConfig fixed_config = scene.world;
  fixed_config.integrator.control = Control::fixed;
  fixed_config.integrator.level_min = fixed_config.integrator.level_max = 0;
  return fixed_config;
}

/// The reference runs by name ("reference", and "check" and "noise1..3" when made here).
struct Reference {
  std::map<std::string, std::vector<Sample>> runs;
  std::string source = "auto";  // or the file it was read from
  double dt = 0;                // of a reference made here [s]
};

/// Makes the reference, its check at half the step and the noise runs, and writes reference.csv;
/// false (said on stderr) when one of them fails.
bool make_reference(const Scene& scene, const TradeOptions& options, const Plan& plan, const fs::path& out,
                    Reference& reference) {
  struct Job {
    std::string name;
    double dt;
    std::uint64_t seed;  // 0: unperturbed
  };
  std::vector<Job> jobs{{"reference", reference.dt, 0}, {"check", reference.dt / 2, 0}};
  if (plan.metrics.any_observable())
    for (std::uint64_t seed = 1; seed <= 3; ++seed) jobs.push_back({"noise" + std::to_string(seed), reference.dt, seed});
  std::vector<RunResult> made;  // keeps the runs alive for reference.csv
  made.reserve(jobs.size());
  for (const Job& job : jobs) {
    WorldConfig config = fixed_config_of(scene);
    config.integrator.dt = config.integrator.dt_base = job.dt;
    made.push_back(run_setting(config, plan, job.seed));
    const RunResult& r = made.back();
    say(options.quiet, "  %-9s fixed dt = %-10.4g %8.3g s  %s\n", job.name.c_str(), job.dt, r.wall_time, r.status.c_str());
    if (r.status != "ok") {
      std::fprintf(stderr, "dem trade: the %s run (fixed dt = %.6g s) %s: %s. Choose smaller --fixed steps.\n",
                   job.name.c_str(), job.dt, r.status.c_str(), r.why.c_str());
      return false;
    }
    reference.runs[job.name] = r.samples;
  }
  std::vector<std::pair<std::string, const RunResult*>> named;
  for (std::size_t j = 0; j < jobs.size(); ++j) named.emplace_back(jobs[j].name, &made[j]);
  write_reference(out / "reference.csv", named);
  return true;
}

/// One setting measured: its run and its errors against the reference.
struct Row {
  std::string control;
  double dt, tolerance;
  RunResult result;
  std::vector<double> errors;
};

/// Runs every --fixed step and every --tol tolerance; each doubling run keeps the scene's finest step.
std::vector<Row> run_settings(const Scene& scene, const TradeOptions& options, const Plan& plan) {
  std::vector<Row> rows;
  const IntegratorConfig& scene_integrator = scene.world.integrator;
  const double finest = (scene_integrator.dt_base > 0 ? scene_integrator.dt_base : scene_integrator.dt) *
                        std::ldexp(1.0, scene_integrator.level_min);
  for (double dt : options.fixed) {
    WorldConfig config = fixed_config_of(scene);
    config.integrator.dt = config.integrator.dt_base = dt;
    rows.push_back({"fixed", dt, nan, run_setting(config, plan), {}});
    const Row& row = rows.back();
    say(options.quiet, "  fixed     dt = %-10.4g %8.3g s  %s%s%s\n", dt, row.result.wall_time, row.result.status.c_str(),
        row.result.why.empty() ? "" : ": ", row.result.why.c_str());
  }
  for (double tol : options.tolerances) {
    WorldConfig config = scene.world;
    IntegratorConfig& c = config.integrator;
    c.control = Control::doubling;
    c.tolerance = tol;
    c.dt = c.dt_base = plan.interval;
    c.level_max = 0;
    c.level_min = static_cast<int>(std::clamp(std::floor(std::log2(finest / plan.interval) + 1e-9), -40.0, 0.0));
    rows.push_back({"doubling", plan.interval, tol, run_setting(config, plan), {}});
    const Row& row = rows.back();
    say(options.quiet, "  doubling  tol = %-9.4g %8.3g s  %s%s%s\n", tol, row.result.wall_time, row.result.status.c_str(),
        row.result.why.empty() ? "" : ": ", row.result.why.c_str());
  }
  return rows;
}

/// The reference's own error and the noise floor per metric column, and whether it converged.
struct ReferenceQuality {
  std::vector<double> error, noise;
  bool have_noise = false;
  std::vector<std::string> converged;  // yes, no, unknown
  std::vector<std::string> warnings;
};

ReferenceQuality judge_reference(const Reference& reference_runs, const std::vector<Row>& rows, const Plan& plan,
                                 const std::vector<std::string>& columns) {
  const std::vector<Sample>& reference = reference_runs.runs.at("reference");
  const std::size_t m = columns.size();
  ReferenceQuality q{std::vector<double>(m, nan), std::vector<double>(m, nan), false, {}, {}};
  if (reference_runs.runs.count("check")) q.error = errors_of(reference_runs.runs.at("check"), true, reference, plan.metrics);
  for (const auto& [name, samples] : reference_runs.runs)
    if (name.rfind("noise", 0) == 0) {
      const std::vector<double> e = errors_of(samples, true, reference, plan.metrics);
      for (std::size_t j = 0; j < m; ++j) q.noise[j] = std::isnan(q.noise[j]) ? e[j] : std::max(q.noise[j], e[j]);
      q.have_noise = true;
    }
  const std::vector<double> scale = scales_of(reference, plan.metrics);
  // Converged: the reference's error estimate is a tenth of the smallest error measured (above the noise),
  // or below the noise floor, or at round-off.
  q.converged.assign(m, "unknown");
  for (std::size_t j = 0; j < m; ++j) {
    if (std::isnan(q.error[j])) continue;
    double smallest = inf;
    for (const Row& row : rows)
      if (row.result.status == "ok" && !(q.have_noise && row.errors[j] <= q.noise[j])) smallest = std::min(smallest, row.errors[j]);
    const bool ok = q.error[j] <= 1e-10 * scale[j] || (q.have_noise && q.error[j] <= q.noise[j]) ||
                    q.error[j] <= 0.1 * smallest;
    q.converged[j] = ok ? "yes" : "no";
    if (!ok) {
      char text[300];
      std::snprintf(text, sizeof text,
                    "the reference did not converge for %s: it differs by %.3g from the run at half its step, more than "
                    "a tenth of the smallest error measured (%.3g); refine it with smaller --fixed steps",
                    columns[j].c_str(), q.error[j], smallest);
      q.warnings.push_back(text);
    }
  }
  return q;
}

void write_trade_csv(const fs::path& out, const std::string& method, const std::vector<Row>& rows,
                     const std::vector<std::string>& columns, const ReferenceQuality& q) {
  std::ostringstream s;
  s << "control,method,dt,tolerance,wall_time,particle_steps,force_evaluations,rejected_steps,status";
  for (const std::string& c : columns) s << ',' << c << "_error";
  if (q.have_noise)
    for (const std::string& c : columns) s << ',' << c << "_noise";
  s << '\n';
  for (const Row& row : rows) {
    const RunCounters& c = row.result.counters;
    s << row.control << ',' << method << ',' << number(row.dt) << ',' << (std::isnan(row.tolerance) ? "" : number(row.tolerance))
      << ',' << number(row.result.wall_time) << ',' << c.particle_steps << ',' << c.force_evaluations << ','
      << c.rejected_steps << ',' << row.result.status;
    for (double e : row.errors) s << ',' << number(e);
    if (q.have_noise)
      for (double n : q.noise) s << ',' << number(n);
    s << '\n';
  }
  write_file_atomically(out / "trade.csv", s.str());
}

/// trade_metrics.txt: what each error column measures.
void write_trade_metrics(const fs::path& out, const std::vector<std::string>& columns, const ReferenceQuality& q) {
  std::ostringstream s;
  s << "metric,unit,reference_error,noise,reference_converged,meaning\n";
  for (std::size_t j = 0; j < columns.size(); ++j) {
    const std::string& c = columns[j];
    std::string meaning;
    if (c.rfind("position", 0) == 0 || c.rfind("velocity", 0) == 0)
      meaning = std::string(c.find("max") != std::string::npos ? "largest" : "root mean square") + " distance of " +
                (c[0] == 'p' ? "positions" : "velocities") + " from the reference over particles and sample times";
    for (int o = 0; o < observable_count; ++o)
      if (c == observable_names[o]) meaning = std::string("absolute error of the ") + observable_meanings[o];
    if (c == spectrum_name) meaning = spectrum_meaning;
    s << c << ',' << unit_of(c) << ',' << number(q.error[j]) << ',' << number(q.noise[j]) << ',' << q.converged[j] << ','
      << meaning << '\n';
  }
  write_file_atomically(out / "trade_metrics.txt", s.str());
}

/// trade_reference.txt: how the reference was made.
void write_trade_reference(const fs::path& out, const Scene& scene, const std::string& method,
                           const Reference& reference, const Plan& plan, const ReferenceQuality& q) {
  const double end_time = plan.start + static_cast<double>(plan.count) * plan.interval;
  std::ostringstream s;
  s << "key,value\nscene," << scene.file << "\nmethod," << method << "\nreference," << reference.source
    << "\nreference_dt," << (reference.source == "auto" ? number(reference.dt) : "") << "\ncheck_dt,"
    << (reference.source == "auto" ? number(reference.dt / 2) : "") << "\nnoise_runs,"
    << (q.have_noise ? reference.runs.size() - 2 : 0) << "\ncomparison_interval," << number(plan.interval)
    << "\nend_time," << number(end_time) << "\ndoubling_dt_base," << number(plan.interval)
    << "\ndoubling_level_max,0\nstart_checkpoint," << plan.checkpoint << "\nstart_time," << number(plan.start) << "\n";
  write_file_atomically(out / "trade_reference.txt", s.str());
}

/// The table of settings and errors on stdout.
void print_table(const fs::path& out, const std::vector<Row>& rows, const std::vector<std::string>& columns,
                 const ReferenceQuality& q) {
  const std::size_t m = columns.size();
  std::printf("\n%-8s %-10s %-9s %9s %14s %8s", "control", "dt [s]", "tol", "wall [s]", "particle-steps", "status");
  for (const std::string& c : columns) std::printf(" %15s", (c + "_error").c_str());
  std::printf("\n");
  for (const Row& row : rows) {
    std::printf("%-8s %-10.4g %-9s %9.3g %14llu %8s", row.control.c_str(), row.dt,
                std::isnan(row.tolerance) ? "" : number(row.tolerance).c_str(), row.result.wall_time,
                static_cast<unsigned long long>(row.result.counters.particle_steps), row.result.status.c_str());
    for (std::size_t j = 0; j < m; ++j) {
      const bool in_noise = q.have_noise && row.errors[j] <= q.noise[j];
      std::printf(" %14.4g%s", row.errors[j], in_noise ? "~" : " ");
    }
    std::printf("\n");
  }
  std::printf("reference error (vs. half its step):                      ");
  for (std::size_t j = 0; j < m; ++j) std::printf(" %14.4g ", q.error[j]);
  std::printf("\n");
  if (q.have_noise) {
    std::printf("noise floor (3 perturbed references):                     ");
    for (std::size_t j = 0; j < m; ++j) std::printf(" %14.4g ", q.noise[j]);
    std::printf("\n(~: at or below the noise floor)\n");
  }
  std::printf("metrics (units and meaning): %s\n", (out / "trade_metrics.txt").string().c_str());
}

/// The rows as the recommendation weighs them.
std::vector<CostedRow> costed_rows(const std::vector<Row>& rows) {
  std::vector<CostedRow> costed;
  for (const Row& row : rows)
    costed.push_back({row.control, row.dt, row.tolerance, row.result.counters.particle_steps, row.result.wall_time,
                      row.result.status == "ok", row.errors});
  return costed;
}

/// Per metric column: the cheapest row within its target, else within its noise floor.
std::vector<Choice> recommend_all(const std::vector<CostedRow>& rows, const std::vector<std::string>& columns,
                                  const ReferenceQuality& q, const std::map<std::string, double>& targets) {
  std::vector<Choice> choices;
  for (std::size_t j = 0; j < columns.size(); ++j) {
    const auto target = targets.find(columns[j]);
    choices.push_back(recommend(rows, j, q.have_noise ? q.noise[j] : nan,
                                target == targets.end() ? std::nullopt : std::optional<double>(target->second)));
  }
  return choices;
}

/// "fixed dt = 5e-05 s" or "step doubling tol = 0.001".
std::string setting_text(const CostedRow& row) {
  return row.control == "fixed" ? "fixed dt = " + number(row.dt) + " s" : "step doubling tol = " + number(row.tolerance);
}

/// An error or threshold with its unit ("3.1e-07 J"; a relative distance has none).
std::string amount(double v, const std::string& unit) {
  char text[40];
  std::snprintf(text, sizeof text, "%.3g", v);
  return unit == "1" ? std::string(text) : std::string(text) + " " + unit;
}

/// recommendation.csv: per metric, the outcome (chosen: the row is the cheapest within the threshold;
/// none_within: no row is, the row is the most accurate; needs_target: no floor and no target, no row)
/// and the cheapest fixed and doubling rows within the threshold.
void write_recommendation(const fs::path& out, const std::string& method, const std::vector<CostedRow>& rows,
                          const std::vector<std::string>& columns, const std::vector<Choice>& choices) {
  std::ostringstream s;
  s << "metric,unit,criterion,threshold,outcome,control,method,dt,tolerance,particle_steps,wall_time,error,"
       "cheapest_fixed_dt,cheapest_fixed_particle_steps,cheapest_doubling_tolerance,cheapest_doubling_particle_steps\n";
  for (std::size_t j = 0; j < columns.size(); ++j) {
    const Choice& c = choices[j];
    const bool judged = c.criterion != Criterion::none;
    s << columns[j] << ',' << unit_of(columns[j]) << ',' << criterion_name(c.criterion) << ','
      << (judged ? number(c.threshold) : "") << ',' << (!judged ? "needs_target" : c.chosen ? "chosen" : "none_within");
    const std::optional<std::size_t> shown = c.chosen ? c.chosen : judged ? c.most_accurate : std::nullopt;
    if (shown) {
      const CostedRow& r = rows[*shown];
      s << ',' << r.control << ',' << method << ',' << number(r.dt) << ','
        << (r.control == "fixed" ? "" : number(r.tolerance)) << ',' << r.particle_steps << ',' << number(r.wall_time)
        << ',' << number(r.errors[j]);
    } else {
      s << ",,,,,,,";
    }
    if (c.cheapest_fixed)
      s << ',' << number(rows[*c.cheapest_fixed].dt) << ',' << rows[*c.cheapest_fixed].particle_steps;
    else
      s << ",,";
    if (c.cheapest_doubling)
      s << ',' << number(rows[*c.cheapest_doubling].tolerance) << ',' << rows[*c.cheapest_doubling].particle_steps;
    else
      s << ",,";
    s << '\n';
  }
  write_file_atomically(out / "recommendation.csv", s.str());
}

/// The recommendation on stdout: per metric, the chosen setting and how it compares with the cheapest
/// of the other control; or what missed, or that a --target is needed.
void print_recommendation(const fs::path& out, const std::string& method, const std::vector<CostedRow>& rows,
                          const std::vector<std::string>& columns, const std::vector<Choice>& choices,
                          const std::string& why_no_floor) {
  std::printf("\nrecommendation (%s; cost in particle-steps, which do not depend on the machine; wall time beside):\n",
              method.c_str());
  for (std::size_t j = 0; j < columns.size(); ++j) {
    const Choice& c = choices[j];
    const std::string& metric = columns[j];
    const std::string unit = unit_of(metric);
    if (c.criterion == Criterion::none) {
      std::printf("  %s: no noise floor (%s): give --target %s=VALUE (an absolute error%s%s)\n", metric.c_str(),
                  why_no_floor.c_str(), metric.c_str(), unit == "1" ? "" : " in ", unit == "1" ? "" : unit.c_str());
      continue;
    }
    const std::string against = std::string(c.criterion == Criterion::target ? "target" : "noise floor");
    const std::string threshold = amount(c.threshold, unit);
    if (!c.chosen) {
      if (c.most_accurate)
        std::printf("  %s: no setting is within the %s of %s; the most accurate is %s (error %s)\n", metric.c_str(),
                    against.c_str(), threshold.c_str(), setting_text(rows[*c.most_accurate]).c_str(),
                    amount(rows[*c.most_accurate].errors[j], unit).c_str());
      else
        std::printf("  %s: no setting is within the %s of %s; none finished\n", metric.c_str(), against.c_str(),
                    threshold.c_str());
      continue;
    }
    const CostedRow& chosen = rows[*c.chosen];
    std::printf("  %s: %s: %llu particle-steps, %.3g s, error %s (%s %s)\n", metric.c_str(),
                setting_text(chosen).c_str(), static_cast<unsigned long long>(chosen.particle_steps), chosen.wall_time,
                amount(chosen.errors[j], unit).c_str(), against.c_str(), threshold.c_str());
    const bool fixed = chosen.control == "fixed";
    const std::optional<std::size_t> other = fixed ? c.cheapest_doubling : c.cheapest_fixed;
    const char* other_kind = fixed ? "step doubling tolerance" : "fixed step";
    const bool other_measured =
        std::any_of(rows.begin(), rows.end(), [&](const CostedRow& r) { return (r.control == "fixed") != fixed; });
    if (other) {
      const double ratio = static_cast<double>(chosen.particle_steps) /
                           static_cast<double>(std::max<std::uint64_t>(rows[*other].particle_steps, 1));
      std::printf("      it needs %.2gx the particle-steps of %s, the cheapest %s within the %s\n", ratio,
                  setting_text(rows[*other]).c_str(), other_kind, against.c_str());
    }
    else if (other_measured)
      std::printf("      no %s is within the %s\n", other_kind, against.c_str());
  }
  std::printf("recommendation per metric: %s\n", (out / "recommendation.csv").string().c_str());
}

}  // namespace

int trade_command(const TradeOptions& options) {
  check_options(options);
  const Scene scene = trade_scene(options);
  const std::string method = scene.world.integrator.method == Method::verlet ? "verlet" : "exact";
  const fs::path out = options.out.empty() ? fs::path("out") / scene.name / "trade" : fs::path(options.out);
  fs::create_directories(out);
  const Plan plan = make_plan(scene, options);
  const std::vector<std::string> columns = plan.metrics.columns();
  const std::map<std::string, double> targets = parse_targets(options.targets, columns);
  const double end_time = plan.start + static_cast<double>(plan.count) * plan.interval;
  const std::string from = plan.checkpoint.empty() ? "" : " (" + plan.checkpoint + ")";
  say(options.quiet, "dem trade %s: %s, %zu particles, compared every %.6g s from %.6g s%s up to %.6g s; metrics: %s\n",
      scene.name.c_str(), method.c_str(), scene.world.particles.size(), plan.interval, plan.start, from.c_str(),
      end_time, join(columns, ", ").c_str());

  Reference reference;
  reference.dt = base_step(scene, options) / 8;
  if (!reference_from_file(options)) {
    if (!make_reference(scene, options, plan, out, reference)) return 1;
  } else {
    reference.source = options.reference;
    reference.runs = read_reference(options.reference, plan, scene.world.particles.size());
    say(options.quiet, "  reference from %s (%zu runs)\n", options.reference.c_str(), reference.runs.size());
  }
  std::vector<Row> rows = run_settings(scene, options, plan);
  for (Row& row : rows)
    row.errors = errors_of(row.result.samples, row.result.status == "ok", reference.runs.at("reference"), plan.metrics);
  const ReferenceQuality quality = judge_reference(reference, rows, plan, columns);

  write_trade_csv(out, method, rows, columns, quality);
  write_trade_metrics(out, columns, quality);
  write_trade_reference(out, scene, method, reference, plan, quality);
  const std::vector<CostedRow> costed = costed_rows(rows);
  const std::vector<Choice> choices = recommend_all(costed, columns, quality, targets);
  write_recommendation(out, method, costed, columns, choices);
  if (!options.quiet) {
    print_table(out, rows, columns, quality);
    print_recommendation(out, method, costed, columns, choices,
                         reference_from_file(options) ? "the reference file has no noise runs"
                                                      : "perturbed references are run for observables only");
  }
  std::fflush(stdout);
  for (const std::string& w : quality.warnings) std::fprintf(stderr, "dem trade: warning: %s\n", w.c_str());
  std::fflush(stderr);
  if (options.plot) run_plot_script("dem trade", "plot_trade.py", out / "trade.csv", options.quiet);
  say(options.quiet, "outputs in %s\n", out.string().c_str());
  return 0;
}

}  // namespace dem::cli

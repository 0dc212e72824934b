// `dem trade`: the speed-accuracy trade of a scene (docs/design.md, Measuring the trade). Runs the scene in
// process through the World API at each fixed step (--fixed) and each step-doubling tolerance (--tol),
// compares each run with a reference run at common sync times and writes, into the output folder:
//   trade.csv            one row per setting: control, method, dt, tolerance, cost, status, <metric>_error,
//                        and <metric>_noise when perturbed reference runs gave a noise floor
//   trade_metrics.txt    one row per metric column: unit, reference error estimate, noise, meaning (CSV)
//   trade_reference.txt  how the reference was made (CSV of key,value)
//   reference.csv        the reference's samples, loadable by a later `dem trade --reference FILE`
//   trade.png            by bench/plot_trade.py when Python and matplotlib are there
//
// Common sync times. Every run is sampled at t_k = k T, k = 1..K, where T (the comparison interval) is
// output.interval raised to a whole multiple of the largest fixed step; every fixed step must divide T.
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
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>



#include "engine/cli/commands.h"
#include "engine/cli/plot_script.h"
#include "engine/cli/energy_audit.h"
#include "engine/input_error.h"
#include "engine/atomic_file.h"
#include "engine/world.h"

namespace dem::cli {
namespace {

constexpr double inf = std::numeric_limits<double>::infinity();
constexpr double nan = std::numeric_limits<double>::quiet_NaN();

// ---------------------------------------------------------------------------------------------------
// Metrics

/// Observables of a many-body scene, measured at every sample time and compared at the end time.
enum Observable { dissipated_energy, bed_height, kinetic_energy, wall_force, power_draw, observable_count };
const char* const observable_names[observable_count] = {"dissipated_energy", "bed_height", "kinetic_energy",
                                                        "wall_force", "power_draw"};
const char* const observable_units[observable_count] = {"J", "m", "J", "N", "W"};
const char* const observable_meanings[observable_count] = {
    "energy dissipated by contacts since the start; at the end time",
    "mean height (along -gravity; z without gravity; y in 2D) of the highest 10% of particles; at the end time",
    "translational plus rotational kinetic energy; at the end time",
    "sum over walls of the magnitude of the force of the particles on the wall; at the end time",
    "mean power of the moving walls on the particles since the start (a mill's drive power): wall work / time; at the end time"};

/// The collision energy spectrum (a mill's): compared as a whole at the end time.
const char* const spectrum_name = "collision_spectrum";
const char* const spectrum_meaning =
    "distance of the collision energy spectra: over ball-ball and ball-liner events, impact energy and normal and "
    "tangential loss, and every bin, the sum of |E_run - E_ref| over the sum of E_run + E_ref (E: energy booked in "
    "the bin by the events ended since the start); 0 for the same spectrum, 1 for disjoint ones; at the end time";

/// The metric columns: the four trajectory columns, the observables and the spectrum, in this order
/// when chosen.
struct Metrics {
  bool trajectory = false;
  bool observable[observable_count] = {false, false, false, false, false};
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
  return m;
}

// ---------------------------------------------------------------------------------------------------
// Runs

/// The state of a run at one sample time; positions and velocities in id order (trajectory metric only).
struct Sample {
  double time = 0;
  std::vector<Vec3> position, velocity;
  double observable[observable_count] = {nan, nan, nan, nan, nan};
  std::vector<double> spectrum;  // energy per (kind, quantity, bin) [J]; empty: none booked or not read
};

struct RunResult {
  std::string status = "ok";  // ok, diverged, failed
  std::string why;            // for diverged and failed
  double wall_time = 0;       // [s]
  RunCounters counters;
  std::vector<Sample> samples;  // k = 0..K
};

Vec3 up_direction(const WorldConfig& config) {
  const Vec3 g = config.model.gravity;
  if (g.norm() > 0) return -g.normalized();
  return config.model.dimension == 2 ? Vec3(0, 1, 0) : Vec3(0, 0, 1);
}

Sample sample_of(const World& world, bool trajectory, const Vec3& up) {
  Sample s;
  s.time = world.time();
  const State& st = world.state();
  if (trajectory)
    for (std::size_t p = 0; p < st.size(); ++p) {  // slots are in id order
      s.position.push_back(st.position[p]);
      s.velocity.push_back(st.velocity[p]);
    }
  const Energies e = world.energies();
  s.observable[dissipated_energy] = world.dissipated_energy();
  s.observable[kinetic_energy] = e.kinetic + e.rotational;
  std::vector<double> height;
  height.reserve(st.size());
  for (std::size_t p = 0; p < st.size(); ++p) height.push_back(st.position[p].dot(up));
  const std::size_t top = std::max<std::size_t>(1, (height.size() + 9) / 10);
  if (!height.empty()) {
    std::nth_element(height.begin(), height.begin() + static_cast<std::ptrdiff_t>(top - 1), height.end(),
                     std::greater<double>());
    double sum = 0;
    std::sort(height.begin(), height.begin() + static_cast<std::ptrdiff_t>(top), std::greater<double>());
    for (std::size_t k = 0; k < top; ++k) sum += height[k];
    s.observable[bed_height] = sum / static_cast<double>(top);
  }
  double force = 0;
  for (const WallLoad& load : world.wall_loads()) force += load.force.norm();
  s.observable[wall_force] = force;
  s.observable[power_draw] = s.time > 0 ? world.wall_work() / s.time : 0;
  if (const CollisionSpectra* spectra = world.collision_spectra())
    for (int kind = 0; kind < CollisionSpectra::kind_count; ++kind)
      for (int q = 0; q < CollisionSpectra::quantity_count; ++q)
        for (int b = 0; b < CollisionSpectra::bin_count; ++b)
          s.spectrum.push_back(spectra->energy(static_cast<CollisionSpectra::Kind>(kind),
                                               static_cast<CollisionSpectra::Quantity>(q), b));
  return s;
}

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

/// Counter-based draw in [-1, 1] from (seed, particle, component): splitmix64 of a mixed key.
double draw(std::uint64_t seed, std::uint64_t particle, std::uint64_t component) {
  std::uint64_t z = seed * 0x9E3779B97F4A7C15ull ^ (particle + 1) * 0xBF58476D1CE4E5B9ull ^ (component + 7) * 0x94D049BB133111EBull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * 0x1.0p-53 * 2 - 1;
}

/// Perturbs initial velocities by 1e-9 relative and positions by 1e-12 m (per component, seeded).
void perturb(WorldConfig& config, std::uint64_t seed) {
  const int dims = config.model.dimension == 2 ? 2 : 3;
  for (std::size_t p = 0; p < config.particles.size(); ++p) {
    ParticleConfig& c = config.particles[p];
    for (int k = 0; k < dims; ++k) {
      c.velocity[k] *= 1 + 1e-9 * draw(seed, p, static_cast<std::uint64_t>(k));
      c.position[k] += 1e-12 * draw(seed, p, static_cast<std::uint64_t>(k + 3));
    }
  }
}

struct Plan {
  double interval = 0;     // T: the comparison interval [s]
  std::int64_t count = 0;  // K: samples after the start
  Metrics metrics;
  Vec3 up = Vec3::UnitZ();
};

/// Runs `config` to K T, sampling at every k T. Never throws for a failing run: the status says it.
RunResult run_setting(WorldConfig config, const Plan& plan) {
  RunResult r;
  const auto start = std::chrono::steady_clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  try {
    World world(config);
    const double sync = world.sync_interval();
    const double ratio = plan.interval / sync;
    const auto per_sample = static_cast<std::int64_t>(std::llround(ratio));
    if (per_sample < 1 || std::abs(ratio - static_cast<double>(per_sample)) > 1e-6 * ratio)
      throw std::runtime_error("the sync interval " + std::to_string(sync) + " s does not divide the comparison interval");
    EnergyAudit audit(world);
    r.samples.push_back(sample_of(world, plan.metrics.trajectory, plan.up));
    for (std::int64_t k = 1; k <= plan.count && r.status == "ok"; ++k) {
      for (std::int64_t i = 0; i < per_sample; ++i)
        if (world.advance_sync_interval() != StepStatus::ok) {
          r.status = "diverged";
          r.why = "non-finite positions or velocities at t = " + std::to_string(world.time()) + " s";
          break;
        }
      if (r.status != "ok") break;
      if (std::string why = audit.check(world); !why.empty()) {
        r.status = "diverged";
        r.why = why;
        break;
      }
      audit.accept(world);
      r.samples.push_back(sample_of(world, plan.metrics.trajectory, plan.up));
    }
    r.counters = world.counters();
  } catch (const std::exception& e) {
    r.status = "failed";
    r.why = e.what();
  }
  r.wall_time = elapsed();
  return r;
}

// ---------------------------------------------------------------------------------------------------
// Comparison

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

// ---------------------------------------------------------------------------------------------------
// Files

std::string number(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char text[40];
  std::snprintf(text, sizeof text, "%.10g", v);
  return text;
}

std::string full(double v) {
  if (!std::isfinite(v)) return number(v);
  char text[40];
  std::snprintf(text, sizeof text, "%.17g", v);
  return text;
}

std::vector<std::string> split(const std::string& line, char sep) {
  std::vector<std::string> out;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, sep)) out.push_back(field);
  if (!line.empty() && line.back() == sep) out.emplace_back();
  return out;
}

/// reference.csv: `run, time, id, x, y, z, vx, vy, vz, <observables>`: for each run (reference, check,
/// noise1..3) and sample time, one row per particle (trajectory metric) with the observables empty, and
/// one row with id -1 carrying the observables.
void write_reference(const std::filesystem::path& path, const std::vector<std::pair<std::string, const RunResult*>>& runs) {
  std::ostringstream s;
  s << "run,time,id,x,y,z,vx,vy,vz";
  for (const char* name : observable_names) s << ',' << name;
  s << '\n';
  for (const auto& [name, run] : runs)
    for (const Sample& sample : run->samples) {
      for (std::size_t p = 0; p < sample.position.size(); ++p) {
        const Vec3 &x = sample.position[p], &v = sample.velocity[p];
        s << name << ',' << full(sample.time) << ',' << p;
        for (int k = 0; k < 3; ++k) s << ',' << full(x[k]);
        for (int k = 0; k < 3; ++k) s << ',' << full(v[k]);
        for (int o = 0; o < observable_count; ++o) s << ',';
        s << '\n';
      }
      s << name << ',' << full(sample.time) << ",-1,,,,,,";
      for (double o : sample.observable) s << ',' << full(o);
      s << '\n';
    }
  write_file_atomically(path, s.str());
}

/// Reads the runs of a reference file at the plan's sample times: reference.csv of an earlier trade, or
/// a `dem run` trajectories.csv (columns time, id, x, y, z, vx, vy, vz, ...: the reference run only).
std::map<std::string, std::vector<Sample>> read_reference(const std::string& file, const Plan& plan, std::size_t particles) {
  std::ifstream in(file);
  if (!in) throw InputError(file, 0, 0, "--reference", "cannot open the reference file");
  std::string line;
  if (!std::getline(in, line)) throw InputError(file, 1, 0, "--reference", "empty file");
  const std::vector<std::string> header = split(line, ',');
  auto column = [&](const std::string& name) -> int {
    const auto it = std::find(header.begin(), header.end(), name);
    return it == header.end() ? -1 : static_cast<int>(it - header.begin());
  };
  const int c_run = column("run"), c_time = column("time"), c_id = column("id");
  int c_x[6];
  const char* state_names[6] = {"x", "y", "z", "vx", "vy", "vz"};
  for (int k = 0; k < 6; ++k) c_x[k] = column(state_names[k]);
  int c_obs[observable_count];
  for (int o = 0; o < observable_count; ++o) c_obs[o] = column(observable_names[o]);
  if (c_time < 0 || c_id < 0)
    throw InputError(file, 1, 0, "--reference",
                     "expected a reference.csv of `dem trade` or a trajectories.csv of `dem run` (columns time, id, ...)");
  if (plan.metrics.trajectory && std::find(std::begin(c_x), std::end(c_x), -1) != std::end(c_x))
    throw InputError(file, 1, 0, "--reference", "the trajectory metric needs columns x, y, z, vx, vy, vz");
  for (int o = 0; o < observable_count; ++o)
    if (plan.metrics.observable[o] && c_obs[o] < 0)
      throw InputError(file, 1, 0, "--reference", std::string("the metric ") + observable_names[o] + " needs its column");

  std::map<std::string, std::vector<Sample>> runs;
  int line_number = 1;
  auto value = [&](const std::vector<std::string>& f, int c) {
    if (c < 0 || c >= static_cast<int>(f.size()) || f[static_cast<std::size_t>(c)].empty()) return nan;
    try {
      return std::stod(f[static_cast<std::size_t>(c)]);
    } catch (const std::exception&) {
      throw InputError(file, line_number, c + 1, "--reference", "not a number: '" + f[static_cast<std::size_t>(c)] + "'");
    }
  };
  while (std::getline(in, line)) {
    ++line_number;
    if (line.empty()) continue;
    const std::vector<std::string> f = split(line, ',');
    const std::string run = c_run >= 0 && c_run < static_cast<int>(f.size()) ? f[static_cast<std::size_t>(c_run)] : "reference";
    const double t = value(f, c_time);
    const double k_real = t / plan.interval;
    const auto k = static_cast<std::int64_t>(std::llround(k_real));
    if (!(std::abs(k_real - static_cast<double>(k)) <= 1e-6) || k < 0 || k > plan.count) continue;  // not a sample time
    std::vector<Sample>& samples = runs[run];
    if (samples.empty()) samples.resize(static_cast<std::size_t>(plan.count + 1));
    Sample& s = samples[static_cast<std::size_t>(k)];
    s.time = t;
    const double id = value(f, c_id);
    if (id < 0) {
      for (int o = 0; o < observable_count; ++o) s.observable[o] = value(f, c_obs[o]);
    } else if (plan.metrics.trajectory) {
      const auto p = static_cast<std::size_t>(id);
      if (p >= particles) throw InputError(file, line_number, c_id + 1, "--reference", "particle id beyond the scene's particles");
      if (s.position.size() < particles) s.position.assign(particles, Vec3::Constant(nan)), s.velocity.assign(particles, Vec3::Constant(nan));
      s.position[p] = Vec3(value(f, c_x[0]), value(f, c_x[1]), value(f, c_x[2]));
      s.velocity[p] = Vec3(value(f, c_x[3]), value(f, c_x[4]), value(f, c_x[5]));
    }
  }
  if (!runs.count("reference")) throw InputError(file, 0, 0, "--reference", "no reference run in the file");
  for (auto& [name, samples] : runs) {
    for (std::size_t k = 0; k < samples.size(); ++k) {
      const Sample& s = samples[k];
      bool complete = true;
      if (plan.metrics.trajectory) {
        complete = s.position.size() == particles;
        for (std::size_t p = 0; complete && p < particles; ++p) complete = s.position[p].allFinite() && s.velocity[p].allFinite();
      }
      for (int o = 0; o < observable_count; ++o)
        if (plan.metrics.observable[o] && k + 1 == samples.size() && !std::isfinite(s.observable[o])) complete = false;
      if (!complete) {
        char text[200];
        std::snprintf(text, sizeof text,
                      "run '%s' has no complete sample at t = %.9g s (the comparison interval is %.9g s up to %.9g s)",
                      name.c_str(), static_cast<double>(k) * plan.interval, plan.interval,
                      static_cast<double>(plan.count) * plan.interval);
        throw InputError(file, 0, 0, "--reference", text);
      }
    }
  }
  return runs;
}

std::string join(const std::vector<std::string>& items, const std::string& sep) {
  std::string s;
  for (const auto& item : items) s += (s.empty() ? "" : sep) + item;
  return s;
}

}  // namespace

int trade_command(const TradeOptions& options) {
  namespace fs = std::filesystem;
  for (double dt : options.fixed)
    if (!(dt > 0) || !std::isfinite(dt)) throw InputError("--fixed", 0, 0, "", "steps must be finite and > 0, got " + number(dt));
  for (double tol : options.tolerances)
    if (!(tol > 0) || !std::isfinite(tol)) throw InputError("--tol", 0, 0, "", "tolerances must be finite and > 0, got " + number(tol));
  if (options.fixed.empty() && options.tolerances.empty())
    throw InputError("dem trade", 0, 0, "", "nothing to measure: give --fixed DT,DT,... and/or --tol TOL,TOL,...");
  if (!options.method.empty() && options.method != "verlet" && options.method != "exact")
    throw InputError("--method", 0, 0, "", "'" + options.method + "' is not valid; expected verlet or exact");

  std::vector<std::string> overrides = options.overrides;
  if (!options.method.empty()) overrides.push_back("integrator.method=" + options.method);
  Scene scene = load_scene(options.scene, overrides);
  if (options.threads >= 0) scene.world.threads = options.threads;
  if (options.until > 0) scene.run.until = options.until;
  const std::string method = scene.world.integrator.method == Method::verlet ? "verlet" : "exact";
  const bool spectrum_asked = std::find(scene.accuracy.metrics.begin(), scene.accuracy.metrics.end(),
                                        spectrum_name) != scene.accuracy.metrics.end();
  if (spectrum_asked && !(scene.world.collision_spectra && scene.world.integrator.method == Method::verlet))
    throw InputError(scene.file, 0, 0, "accuracy.metrics",
                     "collision_spectrum needs a scene that books collision spectra: a [mill] run with "
                     "integrator.method = \"verlet\"");
  const bool reference_from_file = !options.reference.empty() && options.reference != "auto";
  if (spectrum_asked && reference_from_file)
    throw InputError("--reference", 0, 0, "", "collision_spectrum is not stored in a reference file: use --reference auto "
                                             "or leave collision_spectrum out of accuracy.metrics");
  const fs::path out = options.out.empty() ? fs::path("out") / scene.name / "trade" : fs::path(options.out);
  fs::create_directories(out);

  // The comparison interval: output.interval raised to a multiple of the largest fixed step.
  const double base_dt = options.fixed.empty() ? scene.world.integrator.dt : *std::min_element(options.fixed.begin(), options.fixed.end());
  const double largest = options.fixed.empty() ? base_dt : *std::max_element(options.fixed.begin(), options.fixed.end());
  Plan plan;
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
  plan.count = std::max<std::int64_t>(1, static_cast<std::int64_t>(std::ceil(scene.run.until / plan.interval - 1e-9)));
  plan.metrics = choose_metrics(scene);
  if (reference_from_file) plan.metrics.spectrum = false;  // a default only here: the file holds no spectrum
  plan.up = up_direction(scene.world);
  const std::vector<std::string> columns = plan.metrics.columns();
  const double end_time = static_cast<double>(plan.count) * plan.interval;
  auto say = [&](const char* format, auto... args) {
    if (!options.quiet) {
      std::printf(format, args...);
      std::fflush(stdout);
    }
  };
  say("dem trade %s: %s, %zu particles, compared every %.6g s up to %.6g s; metrics: %s\n", scene.name.c_str(),
      method.c_str(), scene.world.particles.size(), plan.interval, end_time, join(columns, ", ").c_str());

  // The reference, its check at half the step, and the noise runs.
  WorldConfig fixed_config = scene.world;
  fixed_config.integrator.control = Control::fixed;
  fixed_config.integrator.level_min = fixed_config.integrator.level_max = 0;
  const bool noise_runs = plan.metrics.any_observable();
  std::map<std::string, std::vector<Sample>> reference_runs;
  std::vector<RunResult> made;  // keeps the runs alive for reference.csv
  std::string reference_source = "auto";
  const double reference_dt = base_dt / 8;
  if (options.reference.empty() || options.reference == "auto") {
    struct Job {
      std::string name;
      double dt;
      std::uint64_t seed;  // 0: unperturbed
    };
    std::vector<Job> jobs{{"reference", reference_dt, 0}, {"check", reference_dt / 2, 0}};
    if (noise_runs)
      for (std::uint64_t seed = 1; seed <= 3; ++seed) jobs.push_back({"noise" + std::to_string(seed), reference_dt, seed});
    made.reserve(jobs.size());
    for (const Job& job : jobs) {
      WorldConfig config = fixed_config;
      config.integrator.dt = config.integrator.dt_base = job.dt;
      if (job.seed > 0) perturb(config, job.seed);
      made.push_back(run_setting(config, plan));
      const RunResult& r = made.back();
      say("  %-9s fixed dt = %-10.4g %8.3g s  %s\n", job.name.c_str(), job.dt, r.wall_time, r.status.c_str());
      if (r.status != "ok") {
        std::fprintf(stderr, "dem trade: the %s run (fixed dt = %.6g s) %s: %s. Choose smaller --fixed steps.\n",
                     job.name.c_str(), job.dt, r.status.c_str(), r.why.c_str());
        return 1;
      }
      reference_runs[job.name] = r.samples;
    }
    std::vector<std::pair<std::string, const RunResult*>> named;
    for (std::size_t j = 0; j < jobs.size(); ++j) named.emplace_back(jobs[j].name, &made[j]);
    write_reference(out / "reference.csv", named);
  } else {
    reference_source = options.reference;
    reference_runs = read_reference(options.reference, plan, scene.world.particles.size());
    say("  reference from %s (%zu runs)\n", options.reference.c_str(), reference_runs.size());
  }
  const std::vector<Sample>& reference = reference_runs.at("reference");

  // The settings.
  struct Row {
    std::string control;
    double dt, tolerance;
    RunResult result;
    std::vector<double> errors;
  };
  std::vector<Row> rows;
  const IntegratorConfig& scene_integrator = scene.world.integrator;
  const double finest = (scene_integrator.dt_base > 0 ? scene_integrator.dt_base : scene_integrator.dt) *
                        std::ldexp(1.0, scene_integrator.level_min);
  for (double dt : options.fixed) {
    WorldConfig config = fixed_config;
    config.integrator.dt = config.integrator.dt_base = dt;
    rows.push_back({"fixed", dt, nan, run_setting(config, plan), {}});
    const Row& row = rows.back();
    say("  fixed     dt = %-10.4g %8.3g s  %s%s%s\n", dt, row.result.wall_time, row.result.status.c_str(),
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
    say("  doubling  tol = %-9.4g %8.3g s  %s%s%s\n", tol, row.result.wall_time, row.result.status.c_str(),
        row.result.why.empty() ? "" : ": ", row.result.why.c_str());
  }
  for (Row& row : rows) row.errors = errors_of(row.result.samples, row.result.status == "ok", reference, plan.metrics);

  // The reference's own error and the noise floor, per metric column.
  const std::size_t m = columns.size();
  std::vector<double> reference_error(m, nan), noise(m, nan);
  if (reference_runs.count("check")) reference_error = errors_of(reference_runs.at("check"), true, reference, plan.metrics);
  bool have_noise = false;
  for (const auto& [name, samples] : reference_runs)
    if (name.rfind("noise", 0) == 0) {
      const std::vector<double> e = errors_of(samples, true, reference, plan.metrics);
      for (std::size_t j = 0; j < m; ++j) noise[j] = std::isnan(noise[j]) ? e[j] : std::max(noise[j], e[j]);
      have_noise = true;
    }
  const std::vector<double> scale = scales_of(reference, plan.metrics);
  // Converged: the reference's error estimate is a tenth of the smallest error measured (above the noise),
  // or below the noise floor, or at round-off.
  std::vector<std::string> converged(m, "unknown");
  std::vector<std::string> warnings;
  for (std::size_t j = 0; j < m; ++j) {
    if (std::isnan(reference_error[j])) continue;
    double smallest = inf;
    for (const Row& row : rows)
      if (row.result.status == "ok" && !(have_noise && row.errors[j] <= noise[j])) smallest = std::min(smallest, row.errors[j]);
    const bool ok = reference_error[j] <= 1e-10 * scale[j] || (have_noise && reference_error[j] <= noise[j]) ||
                    reference_error[j] <= 0.1 * smallest;
    converged[j] = ok ? "yes" : "no";
    if (!ok) {
      char text[300];
      std::snprintf(text, sizeof text,
                    "the reference did not converge for %s: it differs by %.3g from the run at half its step, more than "
                    "a tenth of the smallest error measured (%.3g); refine it with smaller --fixed steps",
                    columns[j].c_str(), reference_error[j], smallest);
      warnings.push_back(text);
    }
  }

  // trade.csv
  {
    std::ostringstream s;
    s << "control,method,dt,tolerance,wall_time,particle_steps,force_evaluations,rejected_steps,status";
    for (const std::string& c : columns) s << ',' << c << "_error";
    if (have_noise)
      for (const std::string& c : columns) s << ',' << c << "_noise";
    s << '\n';
    for (const Row& row : rows) {
      const RunCounters& c = row.result.counters;
      s << row.control << ',' << method << ',' << number(row.dt) << ',' << (std::isnan(row.tolerance) ? "" : number(row.tolerance))
        << ',' << number(row.result.wall_time) << ',' << c.particle_steps << ',' << c.force_evaluations << ','
        << c.rejected_steps << ',' << row.result.status;
      for (double e : row.errors) s << ',' << number(e);
      if (have_noise)
        for (double n : noise) s << ',' << number(n);
      s << '\n';
    }
    write_file_atomically(out / "trade.csv", s.str());
  }
  // trade_metrics.txt: what each error column measures.
  {
    std::ostringstream s;
    s << "metric,unit,reference_error,noise,reference_converged,meaning\n";
    for (std::size_t j = 0; j < m; ++j) {
      const std::string& c = columns[j];
      std::string unit = c.rfind("position", 0) == 0 ? "m" : c.rfind("velocity", 0) == 0 ? "m/s" : "";
      std::string meaning;
      if (c.rfind("position", 0) == 0 || c.rfind("velocity", 0) == 0)
        meaning = std::string(c.find("max") != std::string::npos ? "largest" : "root mean square") + " distance of " +
                  (c[0] == 'p' ? "positions" : "velocities") + " from the reference over particles and sample times";
      for (int o = 0; o < observable_count; ++o)
        if (c == observable_names[o]) unit = observable_units[o], meaning = std::string("absolute error of the ") + observable_meanings[o];
      if (c == spectrum_name) unit = "1", meaning = spectrum_meaning;
      s << c << ',' << unit << ',' << number(reference_error[j]) << ',' << number(noise[j]) << ',' << converged[j] << ','
        << meaning << '\n';
    }
    write_file_atomically(out / "trade_metrics.txt", s.str());
  }
  // trade_reference.txt: how the reference was made.
  {
    std::ostringstream s;
    s << "key,value\nscene," << scene.file << "\nmethod," << method << "\nreference," << reference_source
      << "\nreference_dt," << (reference_source == "auto" ? number(reference_dt) : "") << "\ncheck_dt,"
      << (reference_source == "auto" ? number(reference_dt / 2) : "") << "\nnoise_runs,"
      << (have_noise ? reference_runs.size() - 2 : 0) << "\ncomparison_interval," << number(plan.interval)
      << "\nend_time," << number(end_time) << "\ndoubling_dt_base," << number(plan.interval)
      << "\ndoubling_level_max,0\n";
    write_file_atomically(out / "trade_reference.txt", s.str());
  }

  // The table on stdout.
  if (!options.quiet) {
    std::printf("\n%-8s %-10s %-9s %9s %14s %8s", "control", "dt [s]", "tol", "wall [s]", "particle-steps", "status");
    for (const std::string& c : columns) std::printf(" %15s", (c + "_error").c_str());
    std::printf("\n");
    for (const Row& row : rows) {
      std::printf("%-8s %-10.4g %-9s %9.3g %14llu %8s", row.control.c_str(), row.dt,
                  std::isnan(row.tolerance) ? "" : number(row.tolerance).c_str(), row.result.wall_time,
                  static_cast<unsigned long long>(row.result.counters.particle_steps), row.result.status.c_str());
      for (std::size_t j = 0; j < m; ++j) {
        const bool in_noise = have_noise && row.errors[j] <= noise[j];
        std::printf(" %14.4g%s", row.errors[j], in_noise ? "~" : " ");
      }
      std::printf("\n");
    }
    std::printf("reference error (vs. half its step):                      ");
    for (std::size_t j = 0; j < m; ++j) std::printf(" %14.4g ", reference_error[j]);
    std::printf("\n");
    if (have_noise) {
      std::printf("noise floor (3 perturbed references):                     ");
      for (std::size_t j = 0; j < m; ++j) std::printf(" %14.4g ", noise[j]);
      std::printf("\n(~: at or below the noise floor)\n");
    }
    std::printf("metrics (units and meaning): %s\n", (out / "trade_metrics.txt").string().c_str());
  }
  std::fflush(stdout);
  for (const std::string& w : warnings) std::fprintf(stderr, "dem trade: warning: %s\n", w.c_str());
  std::fflush(stderr);
  if (options.plot) run_plot_script("dem trade", "plot_trade.py", out / "trade.csv", options.quiet);
  say("outputs in %s\n", out.string().c_str());
  return 0;
}

}  // namespace dem::cli

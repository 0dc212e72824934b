// `dem trade`: reading and writing reference files (trade_support.h).
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "engine/input_error.h"
#include "engine/atomic_file.h"
#include "engine/csv_writer.h"
#include "engine/json_writer.h"
#include "engine/cli/trade_support.h"

namespace dem::cli::trade {

std::string number(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char text[40];
  std::snprintf(text, sizeof text, "%.10g", v);
  return text;
}

namespace {

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

}  // namespace

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
    const double k_real = (t - plan.start) / plan.interval;
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
                      name.c_str(), plan.start + static_cast<double>(k) * plan.interval, plan.interval,
                      plan.start + static_cast<double>(plan.count) * plan.interval);
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

}  // namespace dem::cli::trade

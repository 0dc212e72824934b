// mill_power: a program that embeds the engine. It loads a mill scene, runs it with a callback at
// every sync time, and prints the power the drive delivers to the charge, per revolution of the drum
// and as the mean over the steady revolutions: the figures `dem run` prints and writes
// (mill_revolutions.csv, and mean_power_draw in summary.json), from the same MillMonitor.
//
// The monitor takes the power from the work the turning walls do on the charge, which the World
// integrates every step. Beside it the program shows what the embedding API reads at sync times:
//   P = -sum over rotating walls w of Omega_w . T_w   [W]
// with T_w the torque of the particles on wall w about its rotation centre (World::wall_loads) and
// Omega_w its angular velocity now (Walls::angular_velocity), averaged over the revolution's sync
// times. That sampled figure only approximates the drive work (it sees one instant per interval).
//
// Usage: mill_power [scene.toml] [--until T] [--set key.path=value ...]
//   scene.toml defaults to scenes/mill_2d.toml, relative to the working folder; --until and --set as
//   for `dem run` (end time [s], a scene value by dotted path).
#include <cmath>
#include <cstdio>
#include <exception>
#include <optional>
#include <string>
#include <vector>

#include "engine/mill_monitor.h"
#include "engine/scene.h"
#include "engine/world.h"

int main(int argc, char** argv) {
  std::string path = "scenes/mill_2d.toml";
  std::optional<double> until;
  std::vector<std::string> overrides;
  for (int k = 1; k < argc; ++k) {
    const std::string arg = argv[k];
    if ((arg == "--until" || arg == "--set") && k + 1 < argc) {
      if (arg == "--until")
        until = std::stod(argv[++k]);
      else
        overrides.emplace_back(argv[++k]);
    } else if (!arg.empty() && arg[0] != '-') {
      path = arg;
    } else {
      std::fprintf(stderr, "usage: mill_power [scene.toml] [--until T] [--set key.path=value ...]\n");
      return 2;
    }
  }
  try {
    dem::Scene scene;
    const std::unique_ptr<dem::World> world = dem::World::load(path, overrides, &scene);
    if (!scene.mill) {
      std::fprintf(stderr, "mill_power: no [mill] section in %s\n", path.c_str());
      return 1;
    }
    const dem::Walls& walls = world->walls();
    std::vector<std::size_t> driven;  // walls set to rotate: the shell and its lifters
    for (std::size_t w = 0; w < walls.count(); ++w)
      if (walls.config(w).angular_velocity.norm() > 0) driven.push_back(w);

    dem::MillMonitor monitor(*scene.mill, *world);
    std::printf("# %s: %zu rotating walls, one revolution = %.6g s\n", path.c_str(), driven.size(),
                2 * dem::pi / scene.mill->speed);
    std::printf("# revolution  end_time[s]  power_draw[W]  sampled_power[W]  steady\n");
    double sampled = 0;  // sum over the revolution's sync times of -Omega . T times the interval [J]
    const dem::StepStatus status = world->run_until(until.value_or(scene.run.until), [&](const dem::World& w) {
      const std::vector<dem::WallLoad> loads = w.wall_loads();
      for (std::size_t k : driven) sampled -= w.walls().angular_velocity(k).dot(loads[k].torque) * w.sync_interval();
      for (const dem::MillRevolution& r : monitor.observe(w)) {
        std::printf("%12d  %11.6f  %13.6g  %16.6g  %s\n", r.index, r.end, r.power_draw, sampled / (r.end - r.start),
                    r.steady ? "yes" : "no (start-up)");
        sampled = 0;
      }
      return true;
    });
    if (status != dem::StepStatus::ok) {
      std::fprintf(stderr, "mill_power: the run diverged at t = %g s\n", world->time());
      return 3;
    }
    // All 17 digits: the figure summary.json holds, to the bit.
    if (const std::optional<dem::Real> mean = monitor.mean_power_draw())
      std::printf("mean_power_draw %.17g\n", *mean);
    else
      std::printf("# no steady revolution by t = %g s\n", world->time());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mill_power: %s\n", e.what());
    return 2;
  }
  return 0;
}

// mill_power: a program that embeds the engine. It loads a scene, runs it to the scene's end time
// with a callback at every sync time, and prints, per revolution of the drum, the mean power the
// drive delivers to the charge:
//   P = -sum over rotating walls w of Omega_w . T_w   [W]
// with T_w the torque of the particles on wall w about its rotation centre (World::wall_loads) and
// Omega_w its angular velocity now (Walls::angular_velocity). The rotating walls are the shell and
// its lifters; a revolution lasts 2 pi / |Omega| at the shell's full speed, and is counted by the
// angle the shell has turned, so that a start-up ramp (slower first turn) is followed too.
//
// Usage: mill_power [scene.toml]   (default: scenes/mill_2d.toml, relative to the working folder)
#include <cmath>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "engine/scene.h"
#include "engine/world.h"

int main(int argc, char** argv) {
  const std::string path = argc > 1 ? argv[1] : "scenes/mill_2d.toml";
  try {
    dem::Scene scene;
    const std::unique_ptr<dem::World> world = dem::World::load(path, {}, &scene);
    const dem::Walls& walls = world->walls();

    std::vector<std::size_t> driven;  // walls set to rotate: the shell and its lifters
    for (std::size_t w = 0; w < walls.count(); ++w)
      if (walls.config(w).angular_velocity.norm() > 0) driven.push_back(w);
    if (driven.empty()) {
      std::fprintf(stderr, "mill_power: no rotating wall in %s\n", path.c_str());
      return 1;
    }
    const std::size_t shell = world->find_wall("shell").value_or(driven.front());
    const double revolution = 2 * dem::pi / walls.config(shell).angular_velocity.norm();  // [s]

    std::printf("# %s: %zu rotating walls, one revolution = %.6g s\n", path.c_str(), driven.size(), revolution);
    std::printf("# revolution  end_time[s]  mean_power[W]\n");
    int done = 0;       // revolutions completed
    double angle = 0;   // turned by the shell since the start [rad]
    double energy = 0;  // work of the drive since the last revolution ended [J]
    double since = 0;   // time that revolution ended [s]
    const dem::StepStatus status = world->run_until(scene.run.until, [&](const dem::World& w) {
      const std::vector<dem::WallLoad> loads = w.wall_loads();
      double power = 0;  // [W]
      for (std::size_t k : driven) power -= w.walls().angular_velocity(k).dot(loads[k].torque);
      energy += power * w.sync_interval();
      angle += w.walls().angular_velocity(shell).norm() * w.sync_interval();
      if (angle >= 2 * dem::pi * (done + 1)) {
        ++done;
        std::printf("%11d  %11.6f  %13.6g\n", done, w.time(), energy / (w.time() - since));
        energy = 0;
        since = w.time();
      }
      return true;
    });
    if (done == 0) std::printf("# no full revolution by t = %g s\n", world->time());
    if (status != dem::StepStatus::ok) {
      std::fprintf(stderr, "mill_power: the run diverged at t = %g s\n", world->time());
      return 3;
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mill_power: %s\n", e.what());
    return 2;
  }
  return 0;
}

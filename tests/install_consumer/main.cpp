// Built against the installed package by tests/install_test.sh: loads a scene, runs it to an end
// time with a callback at sync times, and prints what the embedding API reads back.
// Usage: consumer <scene.toml> <end time [s]>
#include <cstdio>
#include <exception>
#include <string>

#include "broadphase/candidate_pairs.h"
#include "engine/world.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: consumer <scene.toml> <end time [s]>\n");
    return 2;
  }
  try {
    const std::unique_ptr<dem::World> world = dem::World::load(argv[1], {"run.threads=1"});
    long syncs = 0;
    const dem::StepStatus status = world->run_until(std::stod(argv[2]), [&](const dem::World&) {
      ++syncs;
      return true;
    });
    // Newton's third law through the public API: the contacts on wall 0 against its load.
    dem::Vec3 load = dem::Vec3::Zero();
    const std::vector<dem::ContactForce> contacts = world->contact_forces();
    for (const dem::ContactForce& c : contacts)
      if (c.wall == 0) load -= c.force;
    const bool third_law = world->walls().count() == 0 || load == world->wall_loads()[0].force;
    std::printf("syncs %ld\n", syncs);
    std::printf("particles %zu\n", world->particle_count());
    std::printf("contacts %zu\n", contacts.size());
    std::printf("third_law %s\n", third_law ? "ok" : "broken");
    std::printf("hash %016llx\n", static_cast<unsigned long long>(world->state_hash()));
    return status == dem::StepStatus::ok ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "consumer: %s\n", e.what());
    return 2;
  }
}

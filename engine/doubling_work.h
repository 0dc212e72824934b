#pragma once
// What the World keeps between rounds of step doubling (world_doubling.cpp): the islands of the
// round, each island's cut-out copy, and per-thread scratch. Private to the World.
#include <cstdint>
#include <vector>

#include "engine/island_stepper.h"
#include "engine/islands.h"
#include "engine/parallel.h"

namespace dem {

/// One island of a round: its copy of the particles and contacts, and its own candidate pairs.
struct IslandJob {
  IslandState island;
  broadphase::CandidatePairs candidates;
  std::vector<int> levels;  // per member: its level, in: at the round's start, out: of its next step
};

inline constexpr std::int32_t in_free_flight = -1;
inline constexpr std::int32_t needs_job = -2;

struct DoublingWork {
  explicit DoublingWork(const IslandScratch& exemplar) : scratch(exemplar) {}

  IslandPhysics physics;
  int contact_level = 0;  // steps at or below it resolve any contact (t_c / 8)
  Real skin_cap = 0;      // widest candidate skin a round may ask for [m]

  Islands islands;
  std::vector<std::uint32_t> local_index;  // per particle: its place in its island
  std::vector<ParticleIndex> link_a, link_b;         // contacts and anticipated pairs of the round
  std::vector<ParticleIndex> conflict_a, conflict_b;  // pairs of islands found to interact: redone together
  std::vector<IslandJob> jobs;                        // for islands not in free flight (kept for reuse)
  std::size_t job_count = 0;                          // jobs in use this round
  std::vector<std::int32_t> job_of;                   // per island: its job, or one of the two below
  std::vector<Real> excursion;                        // per particle: farthest from its round start [m]
  State next;                                         // the state at the end of the round
  Walls round_walls;                                  // the walls at the start of the round
  PerThread<IslandScratch> scratch;
  PerThread<DoublingCounters> counters;
};

}  // namespace dem

// Results are bitwise identical for any thread count and any run (docs/design.md, Determinism): the
// state hash after a run with grid rebuilds and contacts created and removed is the same for 1, 2, 3
// and 8 threads (8 oversubscribed) and for a repeat; with either parallel backend
// (tests/thread_support.h).
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "engine/world.h"
#include "tests/test_scenes.h"
#include "tests/thread_support.h"

namespace dem {
namespace {

using test::ThreadRecorder;

struct RunResult {
  std::uint64_t hash;
  std::uint64_t rebuilds;
  std::size_t created;   // contacts at the end that did not exist half way
  std::size_t removed;   // contacts half way that are gone at the end
  std::size_t threads_seen;
  int arena_concurrency;
};

RunResult run(int threads, Method method = Method::verlet) {
  WorldConfig config = test::falling_box_scene(8, 8, 8, 7);
  config.threads = threads;
  if (method == Method::exact) {  // the exact stepper handles frictionless contacts so far
    config.integrator.method = Method::exact;
    config.contacts[0].sliding_friction = 0;
    config.contacts[0].rolling_friction = 0;
  }
  World world(config);
  ThreadRecorder recorder(world.arena());
  constexpr int steps = 600;
  std::vector<std::uint64_t> halfway;
  for (int s = 0; s < steps; ++s) {
    EXPECT_EQ(world.advance_sync_interval(), StepStatus::ok);
    if (s == steps / 2) halfway = world.pair_contacts().key;
  }
  const std::vector<std::uint64_t>& end = world.pair_contacts().key;
  std::vector<std::uint64_t> only_end, only_half;
  std::set_difference(end.begin(), end.end(), halfway.begin(), halfway.end(), std::back_inserter(only_end));
  std::set_difference(halfway.begin(), halfway.end(), end.begin(), end.end(), std::back_inserter(only_half));
  return {world.state_hash(), world.counters().pair_rebuilds, only_end.size(), only_half.size(), recorder.distinct(),
          world.arena().max_concurrency()};
}

TEST(Determinism, SameHashForOneTwoThreeAndEightThreadsAndRepeatedRuns) {
  const test::AllowThreads allow_eight(8);
  const RunResult one = run(1);
  EXPECT_GE(one.rebuilds, 3u) << "the run must rebuild the grid at least twice after the first build";
  EXPECT_GT(one.created, 0u) << "contacts must be created during the run";
  EXPECT_GT(one.removed, 0u) << "contacts must be removed during the run";
  for (int threads : {2, 3, 8}) {
    const RunResult r = run(threads);
    EXPECT_EQ(r.hash, one.hash) << threads << " threads";
    EXPECT_EQ(r.arena_concurrency, threads);
    if (threads == 8) {
      EXPECT_GE(r.threads_seen, 2u) << "at least two threads must have done work";
    }
  }
  EXPECT_EQ(run(2).hash, run(2).hash);
}

TEST(Determinism, ExactStepperSameHashForOneTwoThreeAndEightThreads) {
  const test::AllowThreads allow_eight(8);
  const RunResult one = run(1, Method::exact);
  EXPECT_GT(one.created, 0u);
  EXPECT_GT(one.removed, 0u);
  for (int threads : {2, 3, 8}) EXPECT_EQ(run(threads, Method::exact).hash, one.hash) << threads << " threads";
}

}  // namespace
}  // namespace dem

// Results are bitwise identical for any thread count and any run (STYLE.md, deterministic
// parallelism): the state hash after a run with grid rebuilds and contacts created and removed is the
// same for 1, 2, 3 and 8 threads (8 oversubscribed through tbb::global_control) and for a repeat.
#include <gtest/gtest.h>

#include <algorithm>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

#include <tbb/global_control.h>
#include <tbb/task_scheduler_observer.h>

#include "engine/world.h"
#include "tests/test_scenes.h"

namespace dem {
namespace {

/// Records which OS threads enter the world's arena.
class ThreadRecorder : public tbb::task_scheduler_observer {
 public:
  explicit ThreadRecorder(tbb::task_arena& arena) : tbb::task_scheduler_observer(arena) { observe(true); }
  ~ThreadRecorder() override { observe(false); }
  void on_scheduler_entry(bool) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ids_.insert(std::this_thread::get_id());
  }
  std::size_t distinct() {
    std::lock_guard<std::mutex> lock(mutex_);
    return ids_.size();
  }

 private:
  std::mutex mutex_;
  std::set<std::thread::id> ids_;
};

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
  tbb::global_control allow_eight(tbb::global_control::max_allowed_parallelism, 8);
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
  tbb::global_control allow_eight(tbb::global_control::max_allowed_parallelism, 8);
  const RunResult one = run(1, Method::exact);
  EXPECT_GT(one.created, 0u);
  EXPECT_GT(one.removed, 0u);
  for (int threads : {2, 3, 8}) EXPECT_EQ(run(threads, Method::exact).hash, one.hash) << threads << " threads";
}

}  // namespace
}  // namespace dem

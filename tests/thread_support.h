#pragma once
// Thread-count helpers for the determinism tests, for either backend of broadphase/parallel.h (oneTBB,
// or the std::thread pool of the ThreadSanitizer build), so the same tests run in both builds.
//   AllowThreads allow(8);        lets an arena of up to 8 threads have them all, even on 2 cores
//   ThreadRecorder seen(arena);   ... run ...; seen.distinct(): OS threads that did work in the arena
#include <cstddef>
#include <mutex>
#include <set>
#include <thread>

#include "engine/parallel.h"

#if !DEM_PARALLEL_STD_THREAD
#include <tbb/global_control.h>
#include <tbb/task_scheduler_observer.h>
#endif

namespace dem::test {

#if !DEM_PARALLEL_STD_THREAD

/// oneTBB caps every arena at the core count unless told otherwise, for as long as this lives.
class AllowThreads {
 public:
  explicit AllowThreads(int threads) : control_(tbb::global_control::max_allowed_parallelism, threads) {}

 private:
  tbb::global_control control_;
};

/// Records which OS threads enter the arena.
class ThreadRecorder : public tbb::task_scheduler_observer {
 public:
  explicit ThreadRecorder(TaskArena& arena) : tbb::task_scheduler_observer(arena.native()) { observe(true); }
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

#else

/// The std::thread backend starts every thread an arena asks for: nothing to allow.
class AllowThreads {
 public:
  explicit AllowThreads(int) {}
};

/// The arena's own record: participants that have run a chunk of a loop.
class ThreadRecorder {
 public:
  explicit ThreadRecorder(TaskArena& arena) : arena_(arena) {}
  std::size_t distinct() const { return static_cast<std::size_t>(arena_.threads_used()); }

 private:
  TaskArena& arena_;
};

#endif

}  // namespace dem::test

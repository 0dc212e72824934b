// The std::thread backend of broadphase/parallel.h (compiled only with DEM_PARALLEL_STD_THREAD, the
// ThreadSanitizer build). Reads and writes only the arena's own pool. Threading: a loop is published
// under the pool's mutex with a new generation number; each worker runs its share of chunks, then
// reports back under the mutex, so everything a chunk wrote happens before `run` returns.
#include "broadphase/parallel.h"

#include <sched.h>

#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>

namespace dem::broadphase {
namespace {

thread_local TaskArena* entered_arena = nullptr;  // the arena whose execute this thread is in
thread_local bool in_loop_body = false;           // workers always; the caller while it runs its share

}  // namespace

struct TaskArena::Pool {
  std::mutex loop;   // one loop at a time, whoever calls
  std::mutex mutex;  // guards everything below
  std::condition_variable wake, done;
  std::uint64_t generation = 0;  // of the loop published last
  std::size_t busy = 0;          // workers still running their share of it
  bool stop = false;
  std::size_t chunk_count = 0;
  Chunk chunk = nullptr;
  const void* context = nullptr;
  std::exception_ptr error;      // the first a chunk threw
  std::vector<char> worked;      // per participant: has run a chunk
  std::vector<std::thread> workers;
};

TaskArena::Entered::Entered(TaskArena* arena) : previous(entered_arena) { entered_arena = arena; }
TaskArena::Entered::~Entered() { entered_arena = previous; }

TaskArena::TaskArena(int threads) : threads_(std::max(threads, 1)), pool_(std::make_unique<Pool>()) {
  pool_->worked.assign(static_cast<std::size_t>(threads_), 0);
  for (int p = 1; p < threads_; ++p) pool_->workers.emplace_back([this, p] { work(static_cast<std::size_t>(p)); });
}

TaskArena::~TaskArena() {
  {
    std::lock_guard<std::mutex> lock(pool_->mutex);
    pool_->stop = true;
  }
  pool_->wake.notify_all();
  for (std::thread& t : pool_->workers) t.join();
}

int TaskArena::threads_used() const {
  std::lock_guard<std::mutex> lock(pool_->mutex);
  int used = 0;
  for (char w : pool_->worked) used += w != 0;
  return used;
}

int TaskArena::default_concurrency() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) == 0) return std::max(CPU_COUNT(&set), 1);
  return static_cast<int>(std::max(std::thread::hardware_concurrency(), 1u));
}

int TaskArena::current_concurrency() {
  TaskArena* arena = joinable();
  return arena ? arena->threads_ : 1;
}

TaskArena* TaskArena::joinable() {
  if (in_loop_body || entered_arena == nullptr || entered_arena->threads_ == 1) return nullptr;
  return entered_arena;
}

namespace {

// Runs chunks participant, participant + stride, ...; returns the first exception one threw.
std::exception_ptr run_share(std::size_t participant, std::size_t stride, std::size_t chunk_count,
                             TaskArena::Chunk chunk, const void* context) {
  try {
    for (std::size_t k = participant; k < chunk_count; k += stride) chunk(context, k);
  } catch (...) {
    return std::current_exception();
  }
  return nullptr;
}

}  // namespace

void TaskArena::run(std::size_t chunk_count, Chunk chunk, const void* context) {
  Pool& pool = *pool_;
  const std::lock_guard<std::mutex> one_loop(pool.loop);
  {
    std::lock_guard<std::mutex> lock(pool.mutex);
    pool.chunk_count = chunk_count;
    pool.chunk = chunk;
    pool.context = context;
    pool.error = nullptr;
    pool.busy = pool.workers.size();
    ++pool.generation;
  }
  pool.wake.notify_all();
  in_loop_body = true;
  std::exception_ptr error = run_share(0, static_cast<std::size_t>(threads_), chunk_count, chunk, context);
  in_loop_body = false;
  std::unique_lock<std::mutex> lock(pool.mutex);
  pool.worked[0] = 1;
  pool.done.wait(lock, [&] { return pool.busy == 0; });
  if (!error) error = pool.error;
  lock.unlock();
  if (error) std::rethrow_exception(error);
}

void TaskArena::work(std::size_t participant) {
  Pool& pool = *pool_;
  in_loop_body = true;  // a loop inside a chunk runs on this thread alone
  std::uint64_t seen = 0;
  std::unique_lock<std::mutex> lock(pool.mutex);
  for (;;) {
    pool.wake.wait(lock, [&] { return pool.stop || pool.generation != seen; });
    if (pool.stop) return;
    seen = pool.generation;
    const std::size_t chunk_count = pool.chunk_count;
    const Chunk chunk = pool.chunk;
    const void* context = pool.context;
    lock.unlock();
    std::exception_ptr error = run_share(participant, static_cast<std::size_t>(threads_), chunk_count, chunk, context);
    lock.lock();
    if (participant < chunk_count) pool.worked[participant] = 1;
    if (error && !pool.error) pool.error = error;
    if (--pool.busy == 0) pool.done.notify_one();
  }
}

}  // namespace dem::broadphase
